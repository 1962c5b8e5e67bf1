// `ptir serve`: the persistent engine process (serve_session.h; protocol in
// docs/engine_protocol.md). Requests arrive one JSON object per line on stdin,
// replies leave one JSON object per line on stdout (in request order; a long
// render also sends interim {"id": ID, "progress": f} lines before its reply);
// diagnostics go to stderr. A reader thread takes the lines as they come, so a
// {"cmd": "cancel", "target": ID} stops request ID while it runs (or before it
// starts); {"cmd": "quit"} or the end of stdin ends the process with status 0.
//
//   ptir serve [--threads N] [-q]
#include <tbb/global_control.h>

#include <condition_variable>
#include <cstdio>
#include <deque>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "ptir/core/error.h"
#include "serve_session.h"

namespace ptir::cli {

namespace {

using json = nlohmann::json;

struct ServeOptions {
  int threads = 0;
  bool quiet = false;
};

// Lines from stdin, with cancel requests applied at once.
class RequestQueue {
 public:
  void push(json request) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (request.is_object() && request.value("cmd", "") == "cancel") {
      const int64_t target = request.value("target", int64_t(-1));
      if (target > cancel_upto_) cancel_upto_ = target;
      if (running_id_ >= 0 && running_id_ <= cancel_upto_) cancel_running_ = true;
      return;
    }
    queue_.push_back(std::move(request));
    ready_.notify_one();
  }
  void close() {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
    ready_.notify_one();
  }
  // The next request (nullopt at the end of input); marks it running.
  std::optional<json> next() {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait(lock, [&] { return closed_ || !queue_.empty(); });
    if (queue_.empty()) return std::nullopt;
    json r = std::move(queue_.front());
    queue_.pop_front();
    running_id_ = r.is_object() && r.contains("id") && r["id"].is_number_integer() ? r["id"].get<int64_t>() : -1;
    cancel_running_ = running_id_ >= 0 && running_id_ <= cancel_upto_;
    return r;
  }
  const std::atomic<bool>* cancel_flag() const { return &cancel_running_; }

 private:
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<json> queue_;
  bool closed_ = false;
  int64_t cancel_upto_ = -1, running_id_ = -1;
  std::atomic<bool> cancel_running_{false};
};

void read_requests(RequestQueue* queue) {
  std::string line;
  while (std::getline(std::cin, line)) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    json request;
    try {
      request = json::parse(line);
    } catch (const json::parse_error& e) {
      request = json{{"cmd", "invalid"}, {"error", std::string("invalid JSON request: ") + e.what()}};
    }
    if (request.is_object()) request["_bytes"] = line.size() + 1;
    queue->push(std::move(request));
  }
  queue->close();
}

void send(const json& reply) {
  std::string text = reply.dump() + "\n";
  std::fwrite(text.data(), 1, text.size(), stdout);
  std::fflush(stdout);
}

int run_serve(const ServeOptions& o) {
  std::optional<tbb::global_control> limit;
  if (o.threads < 0) throw Error("--threads must be positive");
  if (o.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(o.threads));
  RequestQueue queue;
  std::thread reader(read_requests, &queue);
  reader.detach();  // blocked on stdin until the parent closes it; the process ends without waiting
  ServeSession session;
  send(json{{"ready", true}, {"protocol", 1}});
  while (std::optional<json> request = queue.next()) {
    const std::string cmd = request->is_object() ? request->value("cmd", "") : "";
    if (cmd == "quit") break;
    json reply;
    if (cmd == "invalid") {
      reply = json{{"ok", false}, {"error", request->value("error", "")}};
    } else {
      uint64_t line_bytes = 0;
      if (request->is_object()) {
        line_bytes = request->value("_bytes", uint64_t(0));
        request->erase("_bytes");
      }
      reply = session.handle(*request, queue.cancel_flag(), send);
      reply["request_bytes"] = line_bytes;
    }
    if (!o.quiet)
      std::fprintf(stderr, "serve: %s %s in %.3f s (%llu + %llu bytes in)\n", cmd.c_str(),
                   reply.value("ok", false) ? "done" : (reply.contains("cancelled") ? "cancelled" : "failed"),
                   reply.value("seconds", 0.0), (unsigned long long)reply.value("request_bytes", uint64_t(0)),
                   (unsigned long long)reply.value("bulk_bytes_in", uint64_t(0)));
    send(reply);
  }
  std::fflush(stdout);
  return 0;
}

}  // namespace

Runner add_serve_command(CLI::App& app) {
  auto o = std::make_shared<ServeOptions>();
  CLI::App* cmd = app.add_subcommand(
      "serve", "Persistent engine: holds a loaded scene and answers JSON requests on stdin (docs/engine_protocol.md)");
  cmd->add_option("--threads", o->threads, "limit worker threads (0: all)");
  cmd->add_flag("-q,--quiet", o->quiet, "no per-request log lines on stderr");
  return [o] { return run_serve(*o); };
}

}  // namespace ptir::cli
