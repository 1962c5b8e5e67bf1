#include "ptir/io/exr_header.h"

#include <cstring>
#include <fstream>
#include <vector>

#include "ptir/core/error.h"

namespace ptir::io {

namespace {
constexpr uint32_t kExrMagic = 20000630;
constexpr uint32_t kMultipartFlag = 0x1000;
constexpr size_t kMaxNameBytes = 256;      // long names (flag 0x400) allow 255 characters
constexpr int kMaxAttributes = 1 << 16;    // per header: far past any real file

uint32_t le32(const unsigned char* b) { return uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24; }
}  // namespace

void check_exr_header(const std::string& path, uint64_t file_size) {
  std::ifstream in(path, std::ios::binary);
  unsigned char head[8];
  if (!in.read(reinterpret_cast<char*>(head), 8) || le32(head) != kExrMagic) return;  // not an EXR
  const bool multipart = (le32(head + 4) & kMultipartFlag) != 0;
  uint64_t pos = 8;
  // A null-terminated string of at most kMaxNameBytes; false at the end of the file.
  auto read_name = [&](std::string& s) {
    s.clear();
    for (char c; in.get(c);) {
      ++pos;
      if (c == '\0') return true;
      if (s.size() >= kMaxNameBytes) throw Error(path, "OpenEXR header: an attribute name is longer than 255 bytes");
      s.push_back(c);
    }
    return false;
  };
  std::string name, type;
  // Headers: attributes until an empty name; a multi-part file ends its list of
  // headers with one more empty name.
  for (int part = 0;; ++part) {
    int count = 0;
    for (;; ++count) {
      if (!read_name(name)) throw Error(path, "OpenEXR header: the file ends inside the header");
      if (name.empty()) break;
      if (count >= kMaxAttributes) throw Error(path, "OpenEXR header: more than 65536 attributes");
      if (!read_name(type)) throw Error(path, "OpenEXR header: the file ends inside attribute '" + name + "'");
      unsigned char sz[4];
      if (!in.read(reinterpret_cast<char*>(sz), 4)) throw Error(path, "OpenEXR header: the file ends inside attribute '" + name + "'");
      pos += 4;
      const int32_t size = int32_t(le32(sz));
      if (size < 0 || uint64_t(size) > file_size - pos)
        throw Error(path, "OpenEXR header: attribute '" + name + "' (" + type + ") declares " + std::to_string(size) +
                              " bytes, more than the file's remaining " + std::to_string(file_size - pos));
      in.seekg(std::streamoff(size), std::ios::cur);
      pos += uint64_t(size);
    }
    if (!multipart) return;
    if (count == 0) return;  // the empty header that ends a multi-part file's headers
  }
}

}  // namespace ptir::io
