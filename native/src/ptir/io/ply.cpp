// Generic PLY reader/writer (see ply.h). The whole file is read into memory at
// once; binary bodies are de-interleaved block by block into per-property
// columns, ASCII bodies are parsed line by line with std::from_chars. Every size
// computed from header values is checked against the bytes the file really has,
// so hostile headers give a ptir::Error, never a crash or a huge allocation.
#include "ptir/io/ply.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string_view>

#include "ptir/core/error.h"
#include "ptir/io/input_file.h"
#include "ptir/io/ply_detail.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "PTIR stores PLY columns in little-endian host order");

namespace ptir::io {

// ---------------------------------------------------------------------------
// Types.

size_t ply_type_size(PlyType t) {
  switch (t) {
    case PlyType::Int8:
    case PlyType::UInt8: return 1;
    case PlyType::Int16:
    case PlyType::UInt16: return 2;
    case PlyType::Int32:
    case PlyType::UInt32:
    case PlyType::Float32: return 4;
    case PlyType::Float64: return 8;
  }
  return 1;
}

const char* ply_type_name(PlyType t) {
  switch (t) {
    case PlyType::Int8: return "char";
    case PlyType::UInt8: return "uchar";
    case PlyType::Int16: return "short";
    case PlyType::UInt16: return "ushort";
    case PlyType::Int32: return "int";
    case PlyType::UInt32: return "uint";
    case PlyType::Float32: return "float";
    case PlyType::Float64: return "double";
  }
  return "?";
}

bool parse_ply_type(std::string_view name, PlyType& out) {
  struct Alias {
    const char* a;
    const char* b;
    PlyType t;
  };
  static const Alias kAliases[] = {{"char", "int8", PlyType::Int8},        {"uchar", "uint8", PlyType::UInt8},
                                   {"short", "int16", PlyType::Int16},     {"ushort", "uint16", PlyType::UInt16},
                                   {"int", "int32", PlyType::Int32},       {"uint", "uint32", PlyType::UInt32},
                                   {"float", "float32", PlyType::Float32}, {"double", "float64", PlyType::Float64}};
  for (const Alias& al : kAliases) {
    if (name == al.a || name == al.b) {
      out = al.t;
      return true;
    }
  }
  return false;
}

double ply_value_as_double(const uint8_t* p, PlyType t) {
  switch (t) {
    case PlyType::Int8: {
      int8_t v;
      std::memcpy(&v, p, 1);
      return v;
    }
    case PlyType::UInt8: return *p;
    case PlyType::Int16: {
      int16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    case PlyType::UInt16: {
      uint16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    case PlyType::Int32: {
      int32_t v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case PlyType::UInt32: {
      uint32_t v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case PlyType::Float32: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case PlyType::Float64: {
      double v;
      std::memcpy(&v, p, 8);
      return v;
    }
  }
  return 0.0;
}

// ---------------------------------------------------------------------------
// Container accessors.

double PlyProperty::as_double(size_t i) const {
  return ply_value_as_double(data.data() + i * ply_type_size(type), type);
}

int PlyElement::find(const std::string& property) const {
  for (size_t i = 0; i < properties.size(); ++i)
    if (properties[i].name == property) return static_cast<int>(i);
  return -1;
}

const PlyProperty* PlyElement::get(const std::string& property) const {
  int i = find(property);
  return i < 0 ? nullptr : &properties[static_cast<size_t>(i)];
}

PlyProperty* PlyElement::get(const std::string& property) {
  int i = find(property);
  return i < 0 ? nullptr : &properties[static_cast<size_t>(i)];
}

std::vector<float> PlyElement::column_as_float(const std::string& property, const std::string& path_for_errors) const {
  const PlyProperty* p = get(property);
  if (!p) throw Error(path_for_errors, "element '" + name + "' has no property '" + property + "'");
  if (p->is_list)
    throw Error(path_for_errors, "property '" + property + "' of element '" + name + "' is a list, expected a scalar");
  std::vector<float> out(count);
  if (p->data.size() != count * ply_type_size(p->type))
    throw Error(path_for_errors, "property '" + property + "' has the wrong number of values");
  if (p->type == PlyType::Float32) {
    if (count) std::memcpy(out.data(), p->data.data(), count * sizeof(float));
  } else {
    for (size_t i = 0; i < count; ++i) out[i] = p->as_float(i);
  }
  return out;
}

void PlyElement::set_float_column(const std::string& property, const std::vector<float>& values) {
  if (values.size() != count)
    throw Error("set_float_column('" + property + "'): " + std::to_string(values.size()) + " values for element '" +
                name + "' of " + std::to_string(count) + " rows");
  PlyProperty* p = get(property);
  if (!p) {
    properties.emplace_back();
    p = &properties.back();
    p->name = property;
  }
  p->type = PlyType::Float32;
  p->is_list = false;
  p->list_offsets.clear();
  p->list_data.clear();
  p->data.resize(count * sizeof(float));
  if (count) std::memcpy(p->data.data(), values.data(), count * sizeof(float));
}

int PlyFile::find(const std::string& element) const {
  for (size_t i = 0; i < elements.size(); ++i)
    if (elements[i].name == element) return static_cast<int>(i);
  return -1;
}

const PlyElement* PlyFile::get(const std::string& element) const {
  int i = find(element);
  return i < 0 ? nullptr : &elements[static_cast<size_t>(i)];
}

PlyElement* PlyFile::get(const std::string& element) {
  int i = find(element);
  return i < 0 ? nullptr : &elements[static_cast<size_t>(i)];
}

// ---------------------------------------------------------------------------
// Header.

namespace {

std::vector<std::string_view> split_ws(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

// Text after the keyword and one separator ("comment made by x" -> "made by x").
std::string rest_after_keyword(std::string_view line, size_t keyword_len) {
  if (line.size() <= keyword_len) return {};
  return std::string(line.substr(keyword_len + 1));
}

// Parses the header; returns the offset of the first body byte.
size_t parse_header(const std::string& path, std::string_view file, PlyFile& ply) {
  auto bad = [&](const std::string& problem) { return Error(path, problem); };
  size_t pos = 0;
  bool first = true, have_format = false;
  while (true) {
    if (pos >= file.size()) {
      if (first) throw bad("not a PLY file (the file is empty; expected the 'ply' magic line)");
      throw bad("truncated: the file ends inside the PLY header (missing end_header)");
    }
    size_t nl = file.find('\n', pos);
    size_t line_end = nl == std::string_view::npos ? file.size() : nl;
    std::string_view line = file.substr(pos, line_end - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = nl == std::string_view::npos ? file.size() : nl + 1;
    // A last line without its line break was cut off: judging its words (a name
    // cut short can repeat an earlier one) would misreport the truncation.
    if (nl == std::string_view::npos && !first && split_ws(line) != std::vector<std::string_view>{"end_header"})
      throw bad("truncated: the file ends inside the PLY header, in the middle of the line '" + std::string(line) + "'");

    if (first) {
      if (line != "ply") throw bad("not a PLY file (missing the 'ply' magic line)");
      first = false;
      continue;
    }
    auto tok = split_ws(line);
    if (tok.empty()) continue;
    const std::string_view kw = tok[0];
    if (kw == "end_header") {
      if (!have_format) throw bad("missing 'format' line in the PLY header");
      return pos;
    } else if (kw == "format") {
      if (tok.size() != 3) throw bad("bad format line '" + std::string(line) + "'");
      if (tok[1] == "ascii")
        ply.format = PlyFormat::Ascii;
      else if (tok[1] == "binary_little_endian")
        ply.format = PlyFormat::BinaryLittleEndian;
      else if (tok[1] == "binary_big_endian")
        ply.format = PlyFormat::BinaryBigEndian;
      else
        throw bad("unsupported format '" + std::string(tok[1]) +
                  "' (expected ascii, binary_little_endian or binary_big_endian)");
      if (tok[2] != "1.0") throw bad("unsupported PLY version '" + std::string(tok[2]) + "' (only 1.0 is supported)");
      have_format = true;
    } else if (kw == "comment") {
      ply.comments.push_back(rest_after_keyword(line, 7));
    } else if (kw == "obj_info") {
      ply.obj_info.push_back(rest_after_keyword(line, 8));
    } else if (kw == "element") {
      uint64_t count = 0;
      if (tok.size() != 3) throw bad("bad element line '" + std::string(line) + "'");
      auto r = std::from_chars(tok[2].data(), tok[2].data() + tok[2].size(), count);
      if (r.ec != std::errc() || r.ptr != tok[2].data() + tok[2].size())
        throw bad("bad element count '" + std::string(tok[2]) + "' in line '" + std::string(line) + "'");
      if (ply.find(std::string(tok[1])) >= 0) throw bad("duplicate element '" + std::string(tok[1]) + "'");
      PlyElement el;
      el.name = std::string(tok[1]);
      el.count = static_cast<size_t>(count);
      ply.elements.push_back(std::move(el));
    } else if (kw == "property") {
      if (ply.elements.empty()) throw bad("property before any element: '" + std::string(line) + "'");
      PlyProperty prop;
      PlyElement& el = ply.elements.back();
      if (tok.size() == 5 && tok[1] == "list") {
        prop.is_list = true;
        if (!parse_ply_type(tok[2], prop.count_type))
          throw bad("unknown property type '" + std::string(tok[2]) + "' in line '" + std::string(line) + "'");
        if (!parse_ply_type(tok[3], prop.type))
          throw bad("unknown property type '" + std::string(tok[3]) + "' in line '" + std::string(line) + "'");
        if (prop.count_type == PlyType::Float32 || prop.count_type == PlyType::Float64)
          throw bad("list count type must be an integer type in line '" + std::string(line) + "'");
        prop.name = std::string(tok[4]);
      } else if (tok.size() == 3 && tok[1] != "list") {
        if (!parse_ply_type(tok[1], prop.type))
          throw bad("unknown property type '" + std::string(tok[1]) + "' in line '" + std::string(line) + "'");
        prop.name = std::string(tok[2]);
      } else {
        throw bad("bad property line '" + std::string(line) + "'");
      }
      if (el.find(prop.name) >= 0) throw bad("duplicate property '" + prop.name + "' in element '" + el.name + "'");
      el.properties.push_back(std::move(prop));
    } else {
      throw bad("unexpected header line '" + std::string(line) + "'");
    }
  }
}

}  // namespace

// ---------------------------------------------------------------------------
// Whole-file read; the body parsers live in ply_body.cpp.

FileBytes::FileBytes(const std::string& path) {
  check_regular_file(path, "file");  // a FIFO or /dev/zero would block or grow without bound
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw Error(path, std::string("cannot open file: ") + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) == 0 && st.st_size > 0 && S_ISREG(st.st_mode)) {
    size_ = static_cast<size_t>(st.st_size);
    void* m = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
    if (m != MAP_FAILED) {
      map_ = m;
      ::close(fd);
      return;
    }
  }
  // Fallback (an empty file, a failed mapping): read until end of file.
  size_ = 0;
  char buf[1 << 16];
  while (true) {
    const ssize_t got = ::read(fd, buf, sizeof buf);
    if (got == 0) break;
    if (got < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      throw Error(path, std::string("cannot read file: ") + std::strerror(err));
    }
    copy_.append(buf, static_cast<size_t>(got));
  }
  ::close(fd);
}

FileBytes::~FileBytes() {
  if (map_) ::munmap(map_, size_);
}

PlyFile read_ply(const std::string& path) {
  const FileBytes file(path);
  const std::string_view bytes = file.view();
  PlyFile ply;
  const size_t body = parse_header(path, bytes, ply);
  if (ply.format == PlyFormat::Ascii) {
    const size_t header_lines = static_cast<size_t>(std::count(bytes.begin(), bytes.begin() + body, '\n'));
    read_ascii_body(path, bytes.data() + body, bytes.size() - body, ply, header_lines + 1);
  } else {
    const auto* data = reinterpret_cast<const uint8_t*>(bytes.data());
    read_binary_body(path, data + body, bytes.size() - body, ply.format == PlyFormat::BinaryBigEndian, ply);
  }
  return ply;
}

}  // namespace ptir::io
