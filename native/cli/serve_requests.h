// The engine protocol's boundary (docs/engine_protocol.md): raw stdin bytes ->
// request objects, for `ptir serve` (cmd_serve.cpp) and its fuzz harness.
//
// Rules (docs/robustness.md):
//  - a line is at most kMaxRequestLine bytes (bulk data travels in files); a
//    longer one is skipped to its end and answered as an error;
//  - a line that is not a JSON object with a "cmd" string (invalid JSON or
//    UTF-8, nesting past kMaxJsonDepth, a number that overflows a double, ...)
//    is answered {"ok": false, "error": ...} on the id the line carries, read
//    from its text when it does not parse ("id": <integer>), else on no id;
//  - "cancel" names a request id seen in this session (an unknown one is an
//    error, never remembered for a later request); it stops that request when
//    it runs or is queued, and does nothing once it has been answered (a later
//    request that reuses the id runs);
//  - every field of a request is one its command reads ("cancel" takes
//    "target", "quit" none): a typo is an error, never ignored;
//  - "quit" and the end of input stop the running request at once.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <initializer_list>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_set>

#include <nlohmann/json.hpp>

namespace ptir::cli {

constexpr size_t kMaxRequestLine = size_t(16) << 20;

// One line, parsed and checked for the envelope ({"cmd": string, "id": integer
// when present}). On failure `error` holds the message and `request` is
// {"id": <the id, recovered from the text when the line did not parse>} or {}.
struct RequestLine {
  nlohmann::json request;
  std::string error;
  bool ok() const { return error.empty(); }
};
RequestLine parse_request_line(const std::string& line);

// Throws Error("request: CMD has no field ...") unless every key of `request`
// (besides "cmd" and "id") is one of `keys`.
void check_keys(const nlohmann::json& request, const std::string& cmd, std::initializer_list<const char*> keys);

// The integer after the first "id": in a line that did not parse (null if none).
nlohmann::json recover_id(const std::string& line);

// Lines of a file descriptor, read without blocking past `stop` (polled every
// 50 ms). A line over the cap is returned as "" with *too_long set.
class LineReader {
 public:
  explicit LineReader(int fd) : fd_(fd) {}
  // False at the end of input (or once stop is set).
  bool next(std::string* line, bool* too_long, const std::atomic<bool>& stop);

 private:
  int fd_;
  std::string buffer_;
  size_t scanned_ = 0;
  bool eof_ = false, skipping_ = false;
};

// A request waiting to run: the object, its line's length, and the error that
// answers it instead when the line was refused.
struct QueuedRequest {
  nlohmann::json request;
  uint64_t bytes = 0;
  std::string error;
};

// Parsed requests waiting to run, with the session's cancel bookkeeping.
class RequestQueue {
 public:
  // Queues a request; a "cancel" is applied at once (and queued as an error
  // reply when its target is not a request of this session).
  void push(QueuedRequest item);
  // No more input ("quit" or end of stdin): the running request is cancelled,
  // and next() returns nullopt once the queue is answered as cancelled.
  void close();
  // The next request (nullopt when closed); marks it running.
  std::optional<QueuedRequest> next();
  // Whether the request being handed out was cancelled before it started.
  bool cancelled_before_start() const { return cancel_running_.load(); }
  const std::atomic<bool>* cancel_flag() const { return &cancel_running_; }
  bool closed() const;

 private:
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<QueuedRequest> queue_;
  bool closed_ = false;
  std::optional<int64_t> running_id_;
  std::unordered_set<int64_t> seen_, cancelled_;
  std::unordered_multiset<int64_t> queued_;  // ids of the requests in queue_
  std::atomic<bool> cancel_running_{false};
};

}  // namespace ptir::cli
