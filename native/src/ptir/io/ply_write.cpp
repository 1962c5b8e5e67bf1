// PLY writer: binary little endian, every property with its original type, lists
// kept. Written atomically (io/atomic_file.h), so a reader never sees a
// half-written file.
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <limits>

#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/io/ply_detail.h"

namespace ptir::io {

namespace {

// Header names and comments must stay on one line and names must be single tokens.
void check_token(const std::string& path, const std::string& what, const std::string& s) {
  if (s.empty() || s.find_first_of(" \t\r\n") != std::string::npos)
    throw Error(path, "cannot write PLY: invalid " + what + " name '" + s + "'");
}

void check_line(const std::string& path, const std::string& s) {
  if (s.find_first_of("\r\n") != std::string::npos)
    throw Error(path, "cannot write PLY: comment contains a line break");
}

// The columns must hold exactly `count` rows; a mismatch is a bug in the caller.
void check_shapes(const std::string& path, const PlyElement& el) {
  check_token(path, "element", el.name);
  for (const PlyProperty& p : el.properties) {
    check_token(path, "property", p.name);
    const std::string where = "property '" + p.name + "' of element '" + el.name + "'";
    if (!p.is_list) {
      if (p.data.size() != el.count * ply_type_size(p.type))
        throw Error(path, "cannot write PLY: " + where + " has " + std::to_string(p.data.size()) + " bytes, expected " +
                              std::to_string(el.count * ply_type_size(p.type)));
      continue;
    }
    if (p.count_type == PlyType::Float32 || p.count_type == PlyType::Float64)
      throw Error(path, "cannot write PLY: " + where + " has a non-integer list count type");
    if (p.list_offsets.size() != el.count + 1 || p.list_offsets.front() != 0 ||
        p.list_offsets.back() * ply_type_size(p.type) != p.list_data.size())
      throw Error(path, "cannot write PLY: " + where + " has inconsistent list offsets");
    for (size_t r = 0; r < el.count; ++r)
      if (p.list_offsets[r + 1] < p.list_offsets[r])
        throw Error(path, "cannot write PLY: " + where + " has decreasing list offsets");
  }
}

std::string header_text(const PlyFile& ply) {
  std::string h = "ply\nformat binary_little_endian 1.0\n";
  for (const std::string& c : ply.comments) h += "comment " + c + "\n";
  for (const std::string& c : ply.obj_info) h += "obj_info " + c + "\n";
  for (const PlyElement& el : ply.elements) {
    h += "element " + el.name + " " + std::to_string(el.count) + "\n";
    for (const PlyProperty& p : el.properties) {
      if (p.is_list)
        h += std::string("property list ") + ply_type_name(p.count_type) + " " + ply_type_name(p.type) + " " + p.name +
             "\n";
      else
        h += std::string("property ") + ply_type_name(p.type) + " " + p.name + "\n";
    }
  }
  h += "end_header\n";
  return h;
}

// Largest list length a count of type t can hold.
uint64_t max_count(PlyType t) {
  switch (t) {
    case PlyType::Int8: return 127;
    case PlyType::UInt8: return 255;
    case PlyType::Int16: return 32767;
    case PlyType::UInt16: return 65535;
    case PlyType::Int32: return 2147483647u;
    default: return 4294967295u;
  }
}

// Buffered output to a FILE*, remembering the first failure's errno.
struct Output {
  FILE* f;
  int error = 0;
  void write(const void* p, size_t n) {
    if (error || n == 0) return;
    if (std::fwrite(p, 1, n, f) != n) error = errno ? errno : EIO;
  }
};

template <size_t N>
void gather(const uint8_t* column, uint8_t* dst, size_t row_size, size_t rows) {
  for (size_t r = 0; r < rows; ++r) std::memcpy(dst + r * row_size, column + r * N, N);
}

void gather_column(size_t value_size, const uint8_t* column, uint8_t* dst, size_t row_size, size_t rows) {
  switch (value_size) {
    case 1: gather<1>(column, dst, row_size, rows); break;
    case 2: gather<2>(column, dst, row_size, rows); break;
    case 4: gather<4>(column, dst, row_size, rows); break;
    default: gather<8>(column, dst, row_size, rows); break;
  }
}

// Scalar-only element: interleave blocks of rows into a buffer and write them.
void write_fixed_rows(Output& out, const PlyElement& el) {
  size_t row_size = 0;
  for (const PlyProperty& p : el.properties) row_size += ply_type_size(p.type);
  if (row_size == 0) return;
  constexpr size_t kBlockRows = 4096;
  std::vector<uint8_t> buf(kBlockRows * row_size);
  for (size_t r0 = 0; r0 < el.count && !out.error; r0 += kBlockRows) {
    const size_t rows = std::min(kBlockRows, el.count - r0);
    size_t offset = 0;
    for (const PlyProperty& p : el.properties) {
      const size_t vs = ply_type_size(p.type);
      gather_column(vs, p.data.data() + r0 * vs, buf.data() + offset, row_size, rows);
      offset += vs;
    }
    out.write(buf.data(), rows * row_size);
  }
}

// Element with lists: row by row into a buffer flushed every ~1 MB.
void write_list_rows(const std::string& path, Output& out, const PlyElement& el) {
  std::vector<uint8_t> buf;
  buf.reserve(1 << 20);
  for (size_t r = 0; r < el.count && !out.error; ++r) {
    for (const PlyProperty& p : el.properties) {
      if (!p.is_list) {
        const size_t vs = ply_type_size(p.type);
        const uint8_t* v = p.data.data() + r * vs;
        buf.insert(buf.end(), v, v + vs);
        continue;
      }
      const uint64_t n = p.list_offsets[r + 1] - p.list_offsets[r];
      if (n > max_count(p.count_type))
        throw Error(path, "cannot write PLY: list '" + p.name + "' row " + std::to_string(r) + " has " +
                              std::to_string(n) + " items, too many for its " + ply_type_name(p.count_type) + " count");
      uint8_t cnt[4];
      const uint32_t n32 = static_cast<uint32_t>(n);
      std::memcpy(cnt, &n32, 4);  // little endian: the low bytes are the narrower count
      buf.insert(buf.end(), cnt, cnt + ply_type_size(p.count_type));
      const size_t is = ply_type_size(p.type);
      const uint8_t* items = p.list_data.data() + p.list_offsets[r] * is;
      buf.insert(buf.end(), items, items + n * is);
    }
    if (buf.size() >= (1 << 20)) {
      out.write(buf.data(), buf.size());
      buf.clear();
    }
  }
  out.write(buf.data(), buf.size());
}

}  // namespace

void write_ply(const std::string& path, const PlyFile& ply) {
  for (const std::string& c : ply.comments) check_line(path, c);
  for (const std::string& c : ply.obj_info) check_line(path, c);
  for (const PlyElement& el : ply.elements) check_shapes(path, el);

  write_atomic(path, [&](const std::string& tmp) {
    FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) throw Error(path, std::string("cannot write file: ") + std::strerror(errno));
    Output out{f};
    try {
      const std::string header = header_text(ply);
      out.write(header.data(), header.size());
      for (const PlyElement& el : ply.elements) {
        bool has_list = false;
        for (const PlyProperty& p : el.properties) has_list |= p.is_list;
        if (has_list)
          write_list_rows(path, out, el);
        else
          write_fixed_rows(out, el);
      }
    } catch (...) {
      std::fclose(f);
      throw;
    }
    if (std::fflush(f) != 0 && !out.error) out.error = errno ? errno : EIO;
    if (std::fclose(f) != 0 && !out.error) out.error = errno ? errno : EIO;
    if (out.error) throw Error(path, std::string("cannot write file: ") + std::strerror(out.error));
  });
}

}  // namespace ptir::io
