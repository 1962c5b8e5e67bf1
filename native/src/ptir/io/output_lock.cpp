#include "ptir/io/output_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>

#include "ptir/core/error.h"

namespace fs = std::filesystem;

namespace ptir::io {

namespace {

// The holder's line from the lock file ("pid 1234, ptir optimize"), or "" when unreadable.
std::string holder_of(int fd) {
  char buf[256] = {};
  const ssize_t n = ::pread(fd, buf, sizeof buf - 1, 0);
  if (n <= 0) return "";
  std::string s(buf, size_t(n));
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
  for (char& c : s)
    if (c == '\n') c = ' ';
  return s;
}

// Whether `fd` is still the file `path` names (a release may have unlinked it).
bool still_named(int fd, const std::string& path) {
  struct stat a {}, b {};
  return ::fstat(fd, &a) == 0 && ::stat(path.c_str(), &b) == 0 && a.st_dev == b.st_dev && a.st_ino == b.st_ino;
}

}  // namespace

OutputLock::OutputLock(const std::string& dir, const std::string& command) : dir_(dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) {
    fs::create_directories(dir, ec);
    if (ec) throw Error(dir, "cannot create the output folder: " + ec.message());
    created_dir_ = true;
  }
  path_ = (fs::path(dir) / kOutputLockName).string();
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int fd = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) return;  // no lock file here (read-only, ...): the writes report it
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      if (err != EWOULDBLOCK) {  // a file system without flock: unlocked
        ::close(fd);
        return;
      }
      const std::string holder = holder_of(fd);
      ::close(fd);
      throw Error(dir, "another process is writing this output folder (" +
                           (holder.empty() ? std::string("its pid is not recorded yet") : holder) +
                           "); wait for it to end, or choose another output folder (one writer per folder: " +
                           path_ + ")");
    }
    if (!still_named(fd, path_)) {  // released and removed between our open and our lock: again
      ::close(fd);
      continue;
    }
    fd_ = fd;
    const std::string line = "pid " + std::to_string(long(::getpid())) + ", " + command + "\n";
    if (::ftruncate(fd_, 0) == 0 && ::pwrite(fd_, line.data(), line.size(), 0) < 0) {
      // A full disk: the lock holds all the same, only the holder's name is missing.
    }
    return;
  }
}

OutputLock::~OutputLock() {
  if (fd_ >= 0) {
    ::unlink(path_.c_str());  // while holding: a waiter re-checks the name (still_named)
    ::close(fd_);
  }
  if (created_dir_) {
    std::error_code ec;
    fs::remove(dir_, ec);  // only when empty: a command that failed before writing leaves no folder
  }
}

}  // namespace ptir::io
