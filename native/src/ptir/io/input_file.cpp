#include "ptir/io/input_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "ptir/core/error.h"

namespace ptir::io {

namespace {

std::string kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

std::string mib(uint64_t bytes) { return std::to_string((bytes + (1 << 20) - 1) >> 20) + " MiB"; }

}  // namespace

uint64_t check_regular_file(const std::string& path, const std::string& what) {
  if (path.find('\0') != std::string::npos) {  // the system would open the name cut at the NUL
    std::string shown;
    for (char c : path) shown += c == '\0' ? std::string("\\0") : std::string(1, c);
    throw Error(shown, "cannot open " + what + ": the name holds a NUL character");
  }
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw Error(path, "cannot open " + what + ": " + (errno == ENOENT ? std::string("file not found (No such file or directory)")
                                                                      : std::string(std::strerror(errno))));
  if (!S_ISREG(st.st_mode)) throw Error(path, what + " is " + kind_of(st.st_mode) + ", not a regular file");
  return uint64_t(st.st_size);
}

std::string read_input_file(const std::string& path, const std::string& what, uint64_t max_bytes) {
  check_regular_file(path, what);
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw Error(path, "cannot open " + what + ": " + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw Error(path, "cannot read " + what + ": " + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) throw Error(path, what + " is " + kind_of(st.st_mode) + ", not a regular file");
  const uint64_t size = uint64_t(st.st_size);
  if (size > max_bytes)
    throw Error(path, what + " is " + mib(size) + ", more than the limit of " + mib(max_bytes) + " for such a file");
  std::string text(size_t(size), '\0');
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::read(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw Error(path, "cannot read " + what + ": " + std::strerror(errno));
    if (n == 0) break;  // shrank while reading
    done += size_t(n);
  }
  text.resize(done);
  return text;
}

}  // namespace ptir::io
