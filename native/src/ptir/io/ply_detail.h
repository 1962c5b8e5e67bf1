// Internal helpers shared by the PLY reader and writer (not part of the public API).
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <utility>

#include "ptir/io/ply.h"

namespace ptir::io {

// "char"/"int8", ..., "double"/"float64" -> PlyType. False for an unknown name.
bool parse_ply_type(std::string_view name, PlyType& out);

// One value of type t (host byte order) at p, converted to double.
double ply_value_as_double(const uint8_t* p, PlyType t);

// The whole file, read-only (memory-mapped; read into memory where mapping fails).
// Throws ptir::Error(path, "cannot open file: <strerror>").
class FileBytes {
 public:
  explicit FileBytes(const std::string& path);
  ~FileBytes();
  FileBytes(const FileBytes&) = delete;
  FileBytes& operator=(const FileBytes&) = delete;
  std::string_view view() const { return map_ ? std::string_view(static_cast<const char*>(map_), size_) : copy_; }

 private:
  void* map_ = nullptr;
  size_t size_ = 0;
  std::string copy_;
};

// Body parsers: fill every element's columns from the bytes after end_header.
// Throw ptir::Error(path, ...) for truncated data, bad values or count mismatches.
void read_binary_body(const std::string& path, const uint8_t* data, size_t size, bool big_endian, PlyFile& ply);
// first_line: line number of the first body line (for messages).
void read_ascii_body(const std::string& path, const char* text, size_t size, PlyFile& ply, size_t first_line);

// Reverses the byte order of `count` values of `size` bytes each, in place.
inline void byte_swap_values(uint8_t* p, size_t count, size_t size) {
  if (size == 1) return;
  for (size_t i = 0; i < count; ++i, p += size)
    for (size_t a = 0, b = size - 1; a < b; ++a, --b) std::swap(p[a], p[b]);
}

}  // namespace ptir::io
