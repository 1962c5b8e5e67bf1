#include "serve_requests.h"

#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <regex>

#include "ptir/core/error.h"
#include "ptir/scene/json_limits.h"

namespace ptir::cli {

using json = nlohmann::json;

namespace {

json invalid(const json& id, const std::string& error, RequestLine* out) {
  json r = json::object();
  if (!id.is_null()) r["id"] = id;
  out->error = error;
  return r;
}

}  // namespace

// Every key of a request is one its command reads (a typo is an error, as in scene files).
void check_keys(const json& request, const std::string& cmd, std::initializer_list<const char*> keys) {
  for (auto it = request.begin(); it != request.end(); ++it) {
    if (it.key() == "cmd" || it.key() == "id") continue;
    bool known = false;
    for (const char* k : keys) known = known || it.key() == k;
    if (!known) {
      std::string list;
      for (const char* k : keys) list += std::string(list.empty() ? "" : ", ") + k;
      throw Error("request: " + cmd + " has no field \"" + it.key() + "\"" +
                  (list.empty() ? std::string(" (it takes none)") : " (it takes " + list + ")"));
    }
  }
}

json recover_id(const std::string& line) {
  static const std::regex pattern(R"re("id"[ \t]*:[ \t]*(-?[0-9]{1,18})[ \t]*([,}]|$))re");
  std::smatch m;
  const std::string head = line.substr(0, 1 << 16);  // ids come early; never scan a huge line
  if (!std::regex_search(head, m, pattern)) return nullptr;
  return json(std::stoll(m[1].str()));
}

RequestLine parse_request_line(const std::string& line) {
  RequestLine out;
  json j;
  try {
    j = parse_json_bounded(line, "request");
  } catch (const Error& e) {
    out.request = invalid(recover_id(line), e.what(), &out);
    return out;
  }
  if (!j.is_object()) {
    out.request = invalid(nullptr, "request: a request is a JSON object, got " + std::string(j.type_name()), &out);
    return out;
  }
  const json id = j.contains("id") ? j.at("id") : json();
  if (!id.is_null() && !id.is_number_integer()) {
    out.request = invalid(id, "request: \"id\" must be an integer", &out);
    return out;
  }
  if (!j.contains("cmd") || !j.at("cmd").is_string()) {
    out.request = invalid(id, "request: a request needs a \"cmd\" string", &out);
    return out;
  }
  out.request = std::move(j);
  return out;
}

bool LineReader::next(std::string* line, bool* too_long, const std::atomic<bool>& stop) {
  for (;;) {
    const size_t nl = buffer_.find('\n', scanned_);
    if (nl != std::string::npos) {
      const bool skipped = skipping_;
      *line = skipped ? std::string() : buffer_.substr(0, nl);
      *too_long = skipped;
      buffer_.erase(0, nl + 1);
      scanned_ = 0;
      skipping_ = false;
      return true;
    }
    scanned_ = buffer_.size();
    if (buffer_.size() > kMaxRequestLine) {  // keep nothing of it; answer it when its end comes
      skipping_ = true;
      buffer_.clear();
      scanned_ = 0;
    }
    if (eof_) {
      if (buffer_.empty() && !skipping_) return false;
      *too_long = skipping_;
      *line = skipping_ ? std::string() : buffer_;
      buffer_.clear();
      scanned_ = 0;
      skipping_ = false;
      return true;
    }
    if (stop.load()) return false;
    pollfd p{fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, 50);
    if (ready < 0 && errno != EINTR) eof_ = true;
    if (ready <= 0) continue;
    char chunk[1 << 16];
    const ssize_t n = ::read(fd_, chunk, sizeof chunk);
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    if (n <= 0) eof_ = true;
    else buffer_.append(chunk, size_t(n));
  }
}

void RequestQueue::push(QueuedRequest item) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (closed_) return;
  const json& request = item.request;
  const std::string cmd = item.error.empty() ? request.at("cmd").get<std::string>() : "";  // checked by parse_request_line
  if (cmd == "cancel" || cmd == "quit") {  // applied here, at once: their fields are checked here too
    try {
      check_keys(request, cmd, cmd == "cancel" ? std::initializer_list<const char*>{"target"}
                                               : std::initializer_list<const char*>{});
    } catch (const Error& e) {  // answered in order, like any request, and not applied
      item.error = e.what();
      queue_.push_back(std::move(item));
      ready_.notify_one();
      return;
    }
  }
  if (cmd == "cancel") {
    const json& t = request.contains("target") ? request.at("target") : json();
    std::string error;
    if (!t.is_number_integer()) error = "request: cancel needs \"target\": the integer id of a request";
    else if (!seen_.count(t.get<int64_t>()))
      error = "request: cancel: no request with id " + t.dump() + " in this session";
    if (!error.empty()) {  // answered in order, like any request
      item.error = error;
      queue_.push_back(std::move(item));
      ready_.notify_one();
      return;
    }
    const int64_t target = t.get<int64_t>();
    if (running_id_ == target) cancel_running_ = true;
    else if (queued_.count(target)) cancelled_.insert(target);  // answered as cancelled when its turn comes
    // else: answered already; a later request that reuses the id is not this one
    return;
  }
  const bool has_id = request.contains("id") && request.at("id").is_number_integer();
  if (has_id) {
    if (seen_.size() > (1u << 20)) seen_.clear();  // a bound on a very long session's memory
    seen_.insert(request.at("id").get<int64_t>());
  }
  if (cmd == "quit") {
    closed_ = true;
    cancel_running_ = true;
    ready_.notify_one();
    return;
  }
  if (has_id) queued_.insert(request.at("id").get<int64_t>());
  queue_.push_back(std::move(item));
  ready_.notify_one();
}

void RequestQueue::close() {
  std::lock_guard<std::mutex> lock(mutex_);
  closed_ = true;
  cancel_running_ = true;
  ready_.notify_one();
}

bool RequestQueue::closed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return closed_;
}

std::optional<QueuedRequest> RequestQueue::next() {
  std::unique_lock<std::mutex> lock(mutex_);
  ready_.wait(lock, [&] { return closed_ || !queue_.empty(); });
  if (queue_.empty()) return std::nullopt;
  QueuedRequest r = std::move(queue_.front());
  queue_.pop_front();
  running_id_.reset();
  if (r.request.contains("id") && r.request.at("id").is_number_integer()) {
    running_id_ = r.request.at("id").get<int64_t>();
    const auto q = queued_.find(*running_id_);
    if (q != queued_.end()) queued_.erase(q);
  }
  // After quit / the end of input, what is still queued is answered as cancelled.
  const bool cancelled = running_id_ && cancelled_.erase(*running_id_) > 0;
  cancel_running_ = closed_ || cancelled;
  return r;
}

}  // namespace ptir::cli
