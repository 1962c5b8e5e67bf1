#include "ptir/io/exr_header.h"

#include <cstring>
#include <fstream>
#include <vector>

#include "ptir/core/error.h"
#include "ptir/io/memory_budget.h"

namespace ptir::io {

namespace {
constexpr uint32_t kExrMagic = 20000630;
constexpr uint32_t kMultipartFlag = 0x1000;
constexpr size_t kMaxNameBytes = 256;      // long names (flag 0x400) allow 255 characters
constexpr int kMaxAttributes = 1 << 16;    // per header: far past any real file

uint32_t le32(const unsigned char* b) { return uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24; }

// The value sizes of the attribute types OpenEXR 3.1 reads field by field, whatever
// size the header declares (Imf*Attribute::readValueFrom): a declared size that
// differs puts OpenEXR's reading out of step with the header, and it then takes
// bytes inside a value for the next attribute (fuzz_image: a chlist read past its
// declared 55 bytes, then a "string" of 1.98 GB allocated). -1: any size.
int fixed_value_size(const std::string& type) {
  static const struct { const char* type; int size; } kSizes[] = {
      {"box2i", 16}, {"box2f", 16}, {"compression", 1}, {"lineOrder", 1}, {"envmap", 1}, {"deepImageState", 1},
      {"float", 4},  {"int", 4},    {"double", 8},      {"v2i", 8},       {"v2f", 8},    {"v2d", 16},
      {"v3i", 12},   {"v3f", 12},   {"v3d", 24},        {"m33f", 36},     {"m33d", 72},  {"m44f", 64},
      {"m44d", 128}, {"rational", 8}, {"timecode", 8},  {"keycode", 28},  {"tiledesc", 9}, {"chromaticities", 32}};
  for (const auto& t : kSizes)
    if (type == t.type) return t.size;
  return -1;
}

// A chlist value: entries (a null-terminated name of 1..255 bytes, then 16 bytes)
// up to an empty name, which must be the value's last byte.
bool chlist_fits(const std::vector<unsigned char>& v) {
  size_t i = 0;
  while (i < v.size()) {
    const size_t start = i;
    while (i < v.size() && v[i] != 0) ++i;
    if (i >= v.size()) return false;  // a name runs past the value
    if (i == start) return i + 1 == v.size();  // the empty name ends the list
    if (i - start > kMaxNameBytes - 1) return false;
    i += 1 + 16;
  }
  return false;
}

// A preview value: width and height, then 4 bytes per pixel.
bool preview_fits(const std::vector<unsigned char>& v) {
  if (v.size() < 8) return false;
  return 8 + 4 * uint64_t(le32(v.data())) * uint64_t(le32(v.data() + 4)) == v.size();
}
// The data window (xMin, yMin, xMax, yMax): OpenEXR allocates its line buffers
// for the declared width when it opens the file, before read_image can check the
// size against the memory budget (fuzz_texture: a 166-byte file declaring a
// width of 14 million). Sides past the engine's limit are refused here.
void check_data_window(std::ifstream& in, const std::string& path) {
  unsigned char b[16];
  if (!in.read(reinterpret_cast<char*>(b), 16)) throw Error(path, "OpenEXR header: the file ends inside 'dataWindow'");
  const int64_t w = int64_t(int32_t(le32(b + 8))) - int32_t(le32(b)) + 1;
  const int64_t h = int64_t(int32_t(le32(b + 12))) - int32_t(le32(b + 4)) + 1;
  if (w < 1 || h < 1 || w > kMaxImageSide || h > kMaxImageSide)
    throw Error(path, "OpenEXR header: dataWindow declares " + std::to_string(w) + "x" + std::to_string(h) +
                          ", outside 1.." + std::to_string(kMaxImageSide) + " pixels a side");
}

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
      const int fixed = fixed_value_size(type);
      if (fixed >= 0 && size != fixed)
        throw Error(path, "OpenEXR header: attribute '" + name + "' (" + type + ") declares " + std::to_string(size) +
                              " bytes, its type has " + std::to_string(fixed));
      if (type == "chlist" || type == "preview") {
        std::vector<unsigned char> value(static_cast<size_t>(size));
        if (!in.read(reinterpret_cast<char*>(value.data()), size))
          throw Error(path, "OpenEXR header: the file ends inside attribute '" + name + "'");
        if (!(type == "chlist" ? chlist_fits(value) : preview_fits(value)))
          throw Error(path, "OpenEXR header: attribute '" + name + "' (" + type + ") does not fill its declared " +
                                std::to_string(size) + " bytes exactly");
      } else if (name == "dataWindow" && type == "box2i") {
        check_data_window(in, path);
      } else {
        in.seekg(std::streamoff(size), std::ios::cur);
      }
      pos += uint64_t(size);
    }
    if (!multipart) return;
    if (count == 0) return;  // the empty header that ends a multi-part file's headers
  }
}

}  // namespace ptir::io
