#include "ptir/pipeline/job_stop.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstring>

namespace ptir::pipeline {

namespace {

// Two buffers: the handler reads the one `g_current` names while the other is rewritten.
char g_message[2][1024];
std::atomic<int> g_current{-1};
std::atomic<bool> g_print{false};

extern "C" void on_job_stop(int sig) {
  const int k = g_current.load();
  if (g_print.load() && k >= 0) {
    const char* m = g_message[k];
    ssize_t ignored = write(STDERR_FILENO, m, std::strlen(m));
    (void)ignored;
  }
  _exit(128 + sig);
}

}  // namespace

void install_job_stop_handlers(bool print) {
  g_print.store(print);
  std::signal(SIGINT, on_job_stop);
  std::signal(SIGTERM, on_job_stop);
}

void set_job_stop_message(const std::string& line) {
  const int next = g_current.load() == 0 ? 1 : 0;
  const size_t n = std::min(line.size(), sizeof g_message[next] - 2);
  std::memcpy(g_message[next], line.data(), n);
  g_message[next][n] = '\n';
  g_message[next][n + 1] = '\0';
  g_current.store(next);
}

}  // namespace ptir::pipeline
