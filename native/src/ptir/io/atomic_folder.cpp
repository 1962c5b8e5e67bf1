#include "ptir/io/atomic_folder.h"

#include <fcntl.h>
#include <stdio.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "ptir/core/error.h"

namespace fs = std::filesystem;

namespace ptir::io {

namespace {

void sync_folder(const fs::path& dir) {
  const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

[[noreturn]] void fail(const std::string& target, const std::string& staged, int err) {
  throw Error(target, "cannot replace it with the finished " + staged + ": " + std::strerror(err));
}

}  // namespace

void replace_folder(const std::string& staged, const std::string& target) {
  std::error_code ec;
  const fs::path parent = fs::path(target).parent_path();
  if (!fs::exists(target, ec)) {
    if (::rename(staged.c_str(), target.c_str()) != 0) fail(target, staged, errno);
    sync_folder(parent);
    return;
  }
  if (::renameat2(AT_FDCWD, staged.c_str(), AT_FDCWD, target.c_str(), RENAME_EXCHANGE) != 0) {
    const int err = errno;
    if (err != EINVAL && err != ENOSYS && err != ENOTSUP) fail(target, staged, err);
    const std::string aside = staged + ".old";  // no exchange here: the old one aside, the new one in
    fs::remove_all(aside, ec);
    if (::rename(target.c_str(), aside.c_str()) != 0) fail(target, staged, errno);
    if (::rename(staged.c_str(), target.c_str()) != 0) {
      const int e2 = errno;
      ::rename(aside.c_str(), target.c_str());
      fail(target, staged, e2);
    }
    sync_folder(parent);
    fs::remove_all(aside, ec);
    return;
  }
  sync_folder(parent);
  fs::remove_all(staged, ec);  // the old contents
}

}  // namespace ptir::io
