#include "ptir/pipeline/run_control.h"

#include <cmath>
#include <csignal>
#include <cstdio>

namespace ptir::pipeline {

std::atomic<bool> g_interrupted{false};

static void on_sigint(int) {
  g_interrupted.store(true);
  std::signal(SIGINT, SIG_DFL);  // a second Ctrl-C ends the process at once
}

SignalHandler install_sigint() {
  g_interrupted.store(false);
  return std::signal(SIGINT, on_sigint);
}

void restore_sigint(SignalHandler previous) { std::signal(SIGINT, previous); }

std::string duration_text(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  long t = long(s + 0.5);
  char b[32];
  if (t >= 3600) std::snprintf(b, sizeof b, "%ldh%02ldm", t / 3600, (t / 60) % 60);
  else if (t >= 60) std::snprintf(b, sizeof b, "%ldm%02lds", t / 60, t % 60);
  else std::snprintf(b, sizeof b, "%.1fs", s);
  return b;
}

}  // namespace ptir::pipeline
