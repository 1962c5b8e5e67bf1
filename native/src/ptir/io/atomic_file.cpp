#include "ptir/io/atomic_file.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <regex>
#include <system_error>

#include "ptir/core/error.h"

namespace fs = std::filesystem;

namespace ptir::io {

namespace {

constexpr const char* kTempTag = ".ptir-tmp-";

void remove_quietly(const fs::path& p) {
  std::error_code ec;
  fs::remove(p, ec);
}

bool process_alive(long pid) {
  if (pid <= 0) return false;
  return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM;
}

}  // namespace

fs::path atomic_temp_path(const fs::path& target) {
  const std::string name = "." + target.stem().string() + kTempTag + std::to_string(static_cast<long>(::getpid())) +
                           target.extension().string();
  return target.parent_path() / name;
}

namespace {

// The finished temp file on disk to its last byte: fsync (a full disk or a
// failing device reports here what buffered writes did not).
void sync_file(const fs::path& tmp, const std::string& path) {
  const int fd = ::open(tmp.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(path, std::string("writing failed: the finished file cannot be reopened: ") + std::strerror(errno));
  const int synced = ::fsync(fd), err = errno;
  ::close(fd);
  if (synced != 0 && err != EINVAL) throw Error(path, std::string("writing failed: ") + std::strerror(err));
}

// The rename on disk too (best effort: some file systems cannot sync a folder).
void sync_folder(const fs::path& dir) {
  const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

}  // namespace

void check_output_target(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
    throw Error(path, S_ISDIR(st.st_mode) ? "is a folder; an output must be a file"
                                          : "exists and is not a regular file (a device, FIFO or socket); refusing to "
                                            "replace it");
}

void write_atomic(const std::string& path, const std::function<void(const std::string&)>& write) {
  const fs::path target(path);
  check_output_target(path);
  const fs::path tmp = atomic_temp_path(target);
  try {
    write(tmp.string());
    sync_file(tmp, path);
  } catch (...) {
    remove_quietly(tmp);
    throw;
  }
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) {
    remove_quietly(tmp);
    throw Error(path, "cannot move the finished file into place: " + ec.message());
  }
  sync_folder(target.parent_path());
}

void write_bytes_atomic(const std::string& path, const void* data, size_t size) {
  write_atomic(path, [&](const std::string& tmp) {
    FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) throw Error(path, std::string("cannot create file: ") + std::strerror(errno));
    bool ok = size == 0 || std::fwrite(data, 1, size, f) == size;
    int err = ok ? 0 : errno;
    if (std::fflush(f) != 0 && ok) ok = false, err = errno;
    if (ok && ::fsync(::fileno(f)) != 0 && errno != EINVAL) ok = false, err = errno;
    if (std::fclose(f) != 0 && ok) ok = false, err = errno;
    if (!ok) throw Error(path, std::string("writing failed: ") + std::strerror(err));
  });
}

void write_text_atomic(const std::string& path, const std::string& text) {
  write_bytes_atomic(path, text.data(), text.size());
}

size_t remove_stale_temps(const fs::path& dir) {
  static const std::regex pattern(R"(^\..*\.ptir-tmp-([0-9]+)(\.[^.]*)?$)");
  size_t removed = 0;
  std::error_code ec;
  fs::directory_iterator it(dir, ec), end;
  if (ec) return 0;
  for (; it != end; it.increment(ec)) {
    if (ec) break;
    const std::string name = it->path().filename().string();
    std::smatch m;
    if (!std::regex_match(name, m, pattern)) continue;
    long pid = std::strtol(m[1].str().c_str(), nullptr, 10);
    if (pid == static_cast<long>(::getpid()) || process_alive(pid)) continue;
    std::error_code rec;
    if (fs::remove(it->path(), rec)) ++removed;
  }
  return removed;
}

}  // namespace ptir::io
