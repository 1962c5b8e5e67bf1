// PLY body parsers: binary (either byte order) and ASCII, into per-property
// columns in host little-endian order. Every count from the header is checked
// against the bytes the file really has before anything is allocated.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>

#include <tbb/parallel_for.h>

#include "ptir/core/error.h"
#include "ptir/io/ply_detail.h"

namespace ptir::io {

namespace {

// ---------------------------------------------------------------------------
// Binary.

// Copies `rows` values of N bytes, one per interleaved row (stride row_size), into a column.
template <size_t N>
void scatter(const uint8_t* src, size_t row_size, uint8_t* column, size_t rows) {
  for (size_t r = 0; r < rows; ++r) std::memcpy(column + r * N, src + r * row_size, N);
}

void scatter_column(size_t value_size, const uint8_t* src, size_t row_size, uint8_t* column, size_t rows) {
  switch (value_size) {
    case 1: scatter<1>(src, row_size, column, rows); break;
    case 2: scatter<2>(src, row_size, column, rows); break;
    case 4: scatter<4>(src, row_size, column, rows); break;
    default: scatter<8>(src, row_size, column, rows); break;
  }
}

std::string bytes_needed(size_t count, size_t row_size) {
  if (count > std::numeric_limits<size_t>::max() / row_size) return "more than 2^64";
  return std::to_string(count * row_size);
}

// Element whose properties are all scalars: fixed row size, de-interleaved in cache-sized blocks.
void read_fixed_rows(const std::string& path, const uint8_t* data, size_t size, size_t& pos, bool swap,
                     PlyElement& el) {
  size_t row_size = 0;
  std::vector<size_t> offset;
  for (const PlyProperty& p : el.properties) {
    offset.push_back(row_size);
    row_size += ply_type_size(p.type);
  }
  if (row_size == 0) return;  // an element without properties occupies no bytes
  const size_t left = size - pos;
  if (el.count > left / row_size)
    throw Error(path, "truncated: element '" + el.name + "' needs " + bytes_needed(el.count, row_size) +
                          " bytes, file has " + std::to_string(left));
  // Columns are allocated (and their pages touched) in parallel, one task per property.
  tbb::parallel_for(size_t(0), el.properties.size(), [&](size_t k) {
    el.properties[k].data.resize(el.count * ply_type_size(el.properties[k].type));
  });

  // Blocks of ~1 MB of source rows (4096 rows of a 62-float splat) stay in cache while
  // every property is gathered from them; blocks are independent, so they run in parallel.
  constexpr size_t kBlockRows = 4096;
  const size_t blocks = (el.count + kBlockRows - 1) / kBlockRows;
  tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
    const size_t r0 = b * kBlockRows, rows = std::min(kBlockRows, el.count - r0);
    const uint8_t* src = data + pos + r0 * row_size;
    for (size_t k = 0; k < el.properties.size(); ++k) {
      PlyProperty& p = el.properties[k];
      const size_t vs = ply_type_size(p.type);
      uint8_t* dst = p.data.data() + r0 * vs;
      scatter_column(vs, src + offset[k], row_size, dst, rows);
      if (swap) byte_swap_values(dst, rows, vs);
    }
  });
  pos += el.count * row_size;
}

// Element with list properties: variable row size, parsed row by row with bounds checks.
void read_list_rows(const std::string& path, const uint8_t* data, size_t size, size_t& pos, bool swap, PlyElement& el) {
  size_t min_row = 0;
  for (const PlyProperty& p : el.properties) min_row += ply_type_size(p.is_list ? p.count_type : p.type);
  const size_t left = size - pos;
  if (el.count > left / min_row)
    throw Error(path, "truncated: element '" + el.name + "' needs at least " + bytes_needed(el.count, min_row) +
                          " bytes, file has " + std::to_string(left));
  for (PlyProperty& p : el.properties) {
    if (p.is_list) {
      p.list_offsets.reserve(el.count + 1);
      p.list_offsets.assign(1, 0);
    } else {
      p.data.resize(el.count * ply_type_size(p.type));
    }
  }
  auto cut_off = [&](size_t row, const PlyProperty& p) {
    return Error(path, "truncated: element '" + el.name + "' row " + std::to_string(row) + " of " +
                           std::to_string(el.count) + " is cut off (property '" + p.name + "')");
  };
  for (size_t r = 0; r < el.count; ++r) {
    for (PlyProperty& p : el.properties) {
      if (!p.is_list) {
        const size_t vs = ply_type_size(p.type);
        if (size - pos < vs) throw cut_off(r, p);
        uint8_t* dst = p.data.data() + r * vs;
        std::memcpy(dst, data + pos, vs);
        if (swap) byte_swap_values(dst, 1, vs);
        pos += vs;
        continue;
      }
      // List: an integer count, then that many items.
      const size_t cs = ply_type_size(p.count_type);
      if (size - pos < cs) throw cut_off(r, p);
      uint8_t tmp[8];
      std::memcpy(tmp, data + pos, cs);
      if (swap) byte_swap_values(tmp, 1, cs);
      pos += cs;
      const double n = ply_value_as_double(tmp, p.count_type);
      const std::string where = " in element '" + el.name + "' row " + std::to_string(r) + " property '" + p.name + "'";
      if (n < 0) throw Error(path, "negative list count " + std::to_string(static_cast<long long>(n)) + where);
      const size_t items = static_cast<size_t>(n);
      const size_t is = ply_type_size(p.type);
      if (items > (size - pos) / is)
        throw Error(path, "truncated: list count " + std::to_string(items) + where + " exceeds the " +
                              std::to_string(size - pos) + " bytes left in the file");
      const size_t start = p.list_data.size();
      p.list_data.insert(p.list_data.end(), data + pos, data + pos + items * is);
      if (swap) byte_swap_values(p.list_data.data() + start, items, is);
      pos += items * is;
      p.list_offsets.push_back(p.list_offsets.back() + items);
    }
  }
}

// ---------------------------------------------------------------------------
// ASCII.

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// Splits the text into lines; skips blank ones; tracks the line number for messages.
struct LineReader {
  const char* p;
  const char* end;
  size_t line_no;

  bool next(std::string_view& line) {
    while (p < end) {
      const char* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<size_t>(end - p)));
      const char* le = nl ? nl : end;
      line = std::string_view(p, static_cast<size_t>(le - p));
      p = nl ? nl + 1 : end;
      ++line_no;
      for (char c : line)
        if (!is_space(c)) return true;
    }
    return false;
  }
};

// Next whitespace-separated token of a line; empty at the end.
std::string_view next_token(std::string_view line, size_t& i) {
  while (i < line.size() && is_space(line[i])) ++i;
  size_t j = i;
  while (j < line.size() && !is_space(line[j])) ++j;
  std::string_view tok = line.substr(i, j - i);
  i = j;
  return tok;
}

enum class Parsed { Ok, NotNumber, OutOfRange };

template <typename F>
Parsed parse_float(std::string_view tok, F& out) {
  if (!tok.empty() && tok[0] == '+') tok.remove_prefix(1);
  auto r = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  if (r.ec == std::errc::result_out_of_range) return Parsed::OutOfRange;
  if (r.ec != std::errc() || r.ptr != tok.data() + tok.size() || tok.empty()) return Parsed::NotNumber;
  return Parsed::Ok;
}

template <typename I>
Parsed parse_int(std::string_view tok, uint8_t* dst) {
  if (!tok.empty() && tok[0] == '+') tok.remove_prefix(1);
  int64_t v = 0;
  auto r = std::from_chars(tok.data(), tok.data() + tok.size(), v);
  if (r.ec != std::errc() || r.ptr != tok.data() + tok.size() || tok.empty()) {
    // Some writers print integers as "3.0": accept integral decimal values.
    double d = 0;
    if (parse_float(tok, d) != Parsed::Ok)
      return r.ec == std::errc::result_out_of_range ? Parsed::OutOfRange : Parsed::NotNumber;
    if (!std::isfinite(d) || d != std::floor(d)) return Parsed::NotNumber;
    if (d < static_cast<double>(std::numeric_limits<I>::min()) ||
        d > static_cast<double>(std::numeric_limits<I>::max()))
      return Parsed::OutOfRange;
    v = static_cast<int64_t>(d);
  }
  if (v < static_cast<int64_t>(std::numeric_limits<I>::min()) ||
      v > static_cast<int64_t>(std::numeric_limits<I>::max()))
    return Parsed::OutOfRange;
  const I value = static_cast<I>(v);
  std::memcpy(dst, &value, sizeof(I));
  return Parsed::Ok;
}

Parsed parse_value(std::string_view tok, PlyType t, uint8_t* dst) {
  switch (t) {
    case PlyType::Int8: return parse_int<int8_t>(tok, dst);
    case PlyType::UInt8: return parse_int<uint8_t>(tok, dst);
    case PlyType::Int16: return parse_int<int16_t>(tok, dst);
    case PlyType::UInt16: return parse_int<uint16_t>(tok, dst);
    case PlyType::Int32: return parse_int<int32_t>(tok, dst);
    case PlyType::UInt32: return parse_int<uint32_t>(tok, dst);
    case PlyType::Float32: {
      float f = 0;
      Parsed r = parse_float(tok, f);
      std::memcpy(dst, &f, 4);
      return r;
    }
    case PlyType::Float64: {
      double d = 0;
      Parsed r = parse_float(tok, d);
      std::memcpy(dst, &d, 8);
      return r;
    }
  }
  return Parsed::NotNumber;
}

}  // namespace

void read_binary_body(const std::string& path, const uint8_t* data, size_t size, bool big_endian, PlyFile& ply) {
  size_t pos = 0;
  for (PlyElement& el : ply.elements) {
    bool has_list =
        std::any_of(el.properties.begin(), el.properties.end(), [](const PlyProperty& p) { return p.is_list; });
    if (has_list)
      read_list_rows(path, data, size, pos, big_endian, el);
    else
      read_fixed_rows(path, data, size, pos, big_endian, el);
  }
  if (pos != size) {
    if (ply.elements.empty())
      throw Error(path, "count mismatch: " + std::to_string(size - pos) +
                            " bytes of data after a header that declares no elements");
    const PlyElement& last = ply.elements.back();
    throw Error(path, "count mismatch: " + std::to_string(size - pos) +
                          " bytes of extra data after the last element '" + last.name + "' (header declares " +
                          std::to_string(last.count) + " rows)");
  }
}

void read_ascii_body(const std::string& path, const char* text, size_t size, PlyFile& ply, size_t first_line) {
  LineReader lines{text, text + size, first_line - 1};
  std::string_view line;
  for (PlyElement& el : ply.elements) {
    if (el.properties.empty()) continue;  // no values, no lines
    // Each row needs at least one non-blank character: bound the allocation by the bytes left.
    const size_t left = static_cast<size_t>(lines.end - lines.p);
    const size_t rows_cap = std::min(el.count, left);
    for (PlyProperty& p : el.properties) {
      if (p.is_list) {
        p.list_offsets.reserve(rows_cap + 1);
        p.list_offsets.assign(1, 0);
      } else {
        p.data.resize(rows_cap * ply_type_size(p.type));
      }
    }
    for (size_t r = 0; r < el.count; ++r) {
      if (!lines.next(line) || r >= rows_cap)
        throw Error(path, "count mismatch: header declares " + std::to_string(el.count) + " '" + el.name +
                              "' rows, file has " + std::to_string(r));
      const std::string where =
          " in element '" + el.name + "' row " + std::to_string(r) + " (line " + std::to_string(lines.line_no) + ")";
      size_t i = 0;
      // Reads one token as type t into dst, with the specific error on failure.
      auto value = [&](const PlyProperty& p, PlyType t, uint8_t* dst) {
        std::string_view tok = next_token(line, i);
        if (tok.empty()) throw Error(path, "too few values" + where + ": property '" + p.name + "' is missing");
        Parsed res = parse_value(tok, t, dst);
        if (res == Parsed::NotNumber)
          throw Error(path, "non-numeric value '" + std::string(tok) + "' for property '" + p.name + "'" + where);
        if (res == Parsed::OutOfRange)
          throw Error(path, "value '" + std::string(tok) + "' out of range for " + ply_type_name(t) + " property '" +
                                p.name + "'" + where);
      };
      for (PlyProperty& p : el.properties) {
        if (!p.is_list) {
          value(p, p.type, p.data.data() + r * ply_type_size(p.type));
          continue;
        }
        uint8_t tmp[8];
        value(p, p.count_type, tmp);
        const double n = ply_value_as_double(tmp, p.count_type);
        if (n < 0) throw Error(path, "negative list count " + std::to_string(static_cast<long long>(n)) + where);
        if (n > static_cast<double>(line.size()))
          throw Error(path, "too few values" + where + ": list '" + p.name + "' declares " +
                                std::to_string(static_cast<long long>(n)) + " items");
        const size_t items = static_cast<size_t>(n), is = ply_type_size(p.type);
        for (size_t k = 0; k < items; ++k) {
          uint8_t item[8];
          value(p, p.type, item);
          p.list_data.insert(p.list_data.end(), item, item + is);
        }
        p.list_offsets.push_back(p.list_offsets.back() + items);
      }
      if (!next_token(line, i).empty()) throw Error(path, "too many values" + where);
    }
  }
  // Anything but whitespace after the last row means the header counts are wrong.
  if (lines.next(line)) {
    std::string shown(line.substr(0, 40));
    if (ply.elements.empty())
      throw Error(path, "count mismatch: data after a header that declares no elements (line " +
                            std::to_string(lines.line_no) + ": '" + shown + "')");
    const PlyElement& last = ply.elements.back();
    throw Error(path, "count mismatch: header declares " + std::to_string(last.count) + " '" + last.name +
                          "' rows, file has extra data after them (line " + std::to_string(lines.line_no) + ": '" +
                          shown + "')");
  }
}

}  // namespace ptir::io
