// Generic PLY container: every element and property of a file, kept with its
// original type so a file can be written back bit-exact.
//
// Reads ascii, binary_little_endian and binary_big_endian PLY 1.0; scalar and
// list properties of every standard type (char/uchar/short/ushort/int/uint/
// float/double and the int8..float64 aliases). Errors are ptir::Error with the
// file name and the problem (truncated data, bad header, count mismatch, ...).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ptir::io {

enum class PlyType : uint8_t { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

size_t ply_type_size(PlyType t);
const char* ply_type_name(PlyType t);  // canonical header name: char, uchar, ..., float, double

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::Float32;  // value type (for lists: the item type)
  bool is_list = false;
  PlyType count_type = PlyType::UInt8;  // lists only

  // Scalar property: count * ply_type_size(type) bytes, host (little-endian) byte order.
  std::vector<uint8_t> data;
  // List property: row r holds items list_offsets[r] .. list_offsets[r+1]-1 in list_data
  // (each item ply_type_size(type) bytes, host order); list_offsets.size() == count + 1.
  std::vector<uint64_t> list_offsets;
  std::vector<uint8_t> list_data;

  // Scalar value of row i converted to double / float (any type).
  double as_double(size_t i) const;
  float as_float(size_t i) const { return static_cast<float>(as_double(i)); }
};

struct PlyElement {
  std::string name;
  size_t count = 0;
  std::vector<PlyProperty> properties;

  // Index of the property with this name, or -1.
  int find(const std::string& property) const;
  const PlyProperty* get(const std::string& property) const;
  PlyProperty* get(const std::string& property);
  // Whole scalar column converted to float. Throws ptir::Error if missing or a list.
  std::vector<float> column_as_float(const std::string& property, const std::string& path_for_errors) const;
  // Adds a Float32 scalar property (or replaces the values and type of an existing one).
  void set_float_column(const std::string& property, const std::vector<float>& values);
};

enum class PlyFormat { Ascii, BinaryLittleEndian, BinaryBigEndian };

struct PlyFile {
  PlyFormat format = PlyFormat::BinaryLittleEndian;
  std::vector<std::string> comments;  // "comment ..." lines, without the keyword
  std::vector<std::string> obj_info;  // "obj_info ..." lines
  std::vector<PlyElement> elements;

  int find(const std::string& element) const;
  const PlyElement* get(const std::string& element) const;
  PlyElement* get(const std::string& element);
};

// Reads the whole file. Throws ptir::Error("<path>: <problem>").
PlyFile read_ply(const std::string& path);

// Writes binary little-endian PLY, atomically (temp file in the same folder + rename).
// Every property keeps its type, so values read and written again are bit-exact.
void write_ply(const std::string& path, const PlyFile& ply);

}  // namespace ptir::io
