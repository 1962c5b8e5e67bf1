// `ptir serve`: the persistent engine process (serve_session.h; protocol in
// docs/engine_protocol.md). Requests arrive one JSON object per line on stdin,
// replies leave one JSON object per line on stdout (in request order; a long
// render also sends interim {"id": ID, "progress": f} lines before its reply);
// diagnostics go to stderr. A reader thread takes the lines as they come, so a
// {"cmd": "cancel", "target": ID} stops request ID while it runs (or before it
// starts); {"cmd": "quit"} or the end of stdin stops the running request, answers
// what is queued as cancelled and ends the process with status 0. Every line is
// answered, whatever it holds (serve_requests.h; docs/robustness.md).
//
// Outputs go only under the folder given with --out (default: the working
// directory): serve_session.h.
//
//   ptir serve [--threads N] [-q] [--max-memory GIB] [--out DIR]
#include <tbb/global_control.h>

#include <condition_variable>
#include <cstdio>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "image_budget.h"
#include "ptir/core/error.h"
#include "ptir/scene/json_limits.h"
#include "serve_requests.h"
#include "serve_session.h"

namespace ptir::cli {

namespace {

using json = nlohmann::json;

struct ServeOptions {
  int threads = 0;
  bool quiet = false;
  double max_memory_gib = 0.0;
  std::string out;
};

// Reads stdin until the end, "quit" or `stop`, queueing each line's request
// (serve_requests.h: malformed lines become error replies on their id).
void read_requests(RequestQueue* queue, const std::atomic<bool>* stop) try {
  LineReader reader(0);
  std::string line;
  bool too_long = false;
  while (!queue->closed() && reader.next(&line, &too_long, *stop)) {
    if (too_long) {
      queue->push({json::object(), 0, "request: a line longer than " + std::to_string(kMaxRequestLine >> 20) +
                                          " MiB (bulk data travels in files)"});
      continue;
    }
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    RequestLine r = parse_request_line(line);
    queue->push({std::move(r.request), line.size() + 1, r.error});
  }
  queue->close();
} catch (const std::exception& e) {  // out of memory: end the session as at the end of input
  std::fprintf(stderr, "serve: cannot read requests: %s\n", e.what());
  queue->close();
}

// The reader thread, stopped and joined however run_serve ends.
struct ReaderThread {
  std::atomic<bool> stop{false};
  std::thread thread;
  ~ReaderThread() {
    stop = true;
    if (thread.joinable()) thread.join();  // polls stdin every 50 ms: ends at once
  }
};

std::mutex send_mutex;

void send(const json& reply) {
  const std::string text = dump_json_safe(reply) + "\n";  // never throws (invalid UTF-8 echoed back is replaced)
  std::lock_guard<std::mutex> lock(send_mutex);
  std::fwrite(text.data(), 1, text.size(), stdout);
  std::fflush(stdout);
}

int run_serve(const ServeOptions& o) {
  std::optional<tbb::global_control> limit;
  if (o.threads < 0) throw Error("--threads must be positive");
  if (o.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(o.threads));
  ServeSession session(ServeLimits{o.max_memory_gib, 0}, o.out);  // (a bad --out ends here, before "ready")
  RequestQueue queue;
  ReaderThread reader;
  reader.thread = std::thread(read_requests, &queue, &reader.stop);
  send(json{{"ready", true}, {"protocol", 1}});
  while (std::optional<QueuedRequest> item = queue.next()) {
    const json& request = item->request;
    const std::string cmd = item->error.empty() ? request.at("cmd").get<std::string>() : "invalid";
    json reply;
    if (!item->error.empty()) {
      reply = json{{"ok", false}, {"error", item->error}, {"seconds", 0.0}, {"bulk_bytes_in", 0}};
      if (request.contains("id")) reply["id"] = request.at("id");
    } else if (queue.cancelled_before_start()) {  // cancelled while queued, or queued before quit
      reply = json{{"ok", false}, {"cancelled", true}, {"seconds", 0.0}, {"bulk_bytes_in", 0}};
      if (request.contains("id")) reply["id"] = request.at("id");
    } else {
      reply = session.handle(request, queue.cancel_flag(), send);
    }
    const uint64_t line_bytes = item->bytes;
    reply["request_bytes"] = line_bytes;
    if (!o.quiet)
      std::fprintf(stderr, "serve: %s %s in %.3f s (%llu + %llu bytes in)\n", cmd.substr(0, 40).c_str(),
                   reply.value("ok", false) ? "done" : (reply.contains("cancelled") ? "cancelled" : "failed"),
                   reply.value("seconds", 0.0), (unsigned long long)line_bytes,
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
  add_max_memory_flag(cmd, o->max_memory_gib);
  cmd->add_option("--out", o->out,
                  "the folder render outputs go in: requests name files under it, and replace only files this "
                  "session wrote (default: the working directory)");
  return [o] { return run_serve(*o); };
}

}  // namespace ptir::cli
