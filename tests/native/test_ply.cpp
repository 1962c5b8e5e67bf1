// Generic PLY reader/writer: bit-exact round trips for every type and format,
// and a specific error for each kind of malformed file.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <sstream>

#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/io/ply.h"
#include "expect_error.h"

using namespace ptir;
using namespace ptir::io;

namespace {

std::string ply_tmp(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(PTIR_TEST_TMP) / "ply";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

void put_file(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary);
  f << bytes;
}

std::string get_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

// Writes `header` + `body` to a temp file and expects read_ply to fail with the phrases.
void expect_bad_ply(const std::string& name, const std::string& contents, std::initializer_list<std::string> phrases) {
  const std::string path = ply_tmp(name);
  put_file(path, contents);
  test::expect_error([&] { read_ply(path); }, path, phrases);
}

// One row of the round-trip data set: one value of each scalar type and a list.
struct Row {
  int8_t a;
  uint8_t b;
  int16_t c;
  uint16_t d;
  int32_t e;
  uint32_t f;
  float g;
  double h;
  std::vector<int32_t> list;
};

const std::vector<Row> kRows = {
    {-128, 255, -32768, 65535, INT32_MIN, 4294967295u, 1.5f, 3.141592653589793, {1, 2, 3}},
    {127, 0, 32767, 0, INT32_MAX, 0u, -0.1f, -1e-300, {}},
    {-1, 7, 12, 345, -6789, 123456u, 3.4028234663852886e38f, 2.5e300, {-5, 6, 7, 8}},
};
const float kExtra[2] = {0.333333343f, -2.0f};

template <typename T>
void append(std::string& out, T v, bool big_endian) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big_endian) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

// Header with either naming scheme for the types.
std::string test_header(const std::string& format, bool aliases) {
  const char* const canon[] = {"char", "uchar", "short", "ushort", "int", "uint", "float", "double"};
  const char* const alias[] = {"int8", "uint8", "int16", "uint16", "int32", "uint32", "float32", "float64"};
  const char* const* t = aliases ? alias : canon;
  std::ostringstream h;
  h << "ply\nformat " << format << " 1.0\ncomment hello world\nobj_info made by hand\n";
  h << "element vertex " << kRows.size() << "\n";
  const char* names = "abcdefgh";
  for (int k = 0; k < 8; ++k) h << "property " << t[k] << " " << names[k] << "\n";
  h << "property list " << t[1] << " " << t[4] << " idx\n";
  h << "element extra 2\nproperty " << t[6] << " w\nend_header\n";
  return h.str();
}

std::string binary_file(bool big_endian) {
  std::string s = test_header(big_endian ? "binary_big_endian" : "binary_little_endian", big_endian);
  for (const Row& r : kRows) {
    append(s, r.a, big_endian);
    append(s, r.b, big_endian);
    append(s, r.c, big_endian);
    append(s, r.d, big_endian);
    append(s, r.e, big_endian);
    append(s, r.f, big_endian);
    append(s, r.g, big_endian);
    append(s, r.h, big_endian);
    append(s, static_cast<uint8_t>(r.list.size()), big_endian);
    for (int32_t v : r.list) append(s, v, big_endian);
  }
  for (float w : kExtra) append(s, w, big_endian);
  return s;
}

std::string ascii_file() {
  std::string s = test_header("ascii", false);
  char buf[512];
  for (const Row& r : kRows) {
    std::snprintf(buf, sizeof buf, "%d %u %d %u %d %u %.9g %.17g %zu", static_cast<int>(r.a),
                  static_cast<unsigned>(r.b), static_cast<int>(r.c), static_cast<unsigned>(r.d), static_cast<int>(r.e),
                  static_cast<unsigned>(r.f), static_cast<double>(r.g), r.h, r.list.size());
    s += buf;
    for (int32_t v : r.list) s += " " + std::to_string(v);
    s += "\n";
  }
  for (float w : kExtra) {
    std::snprintf(buf, sizeof buf, "%.9g\n", w);
    s += buf;
  }
  return s;
}

// Raw host-order bytes the column of property k must hold.
std::vector<uint8_t> expected_column(int k) {
  std::string s;
  for (const Row& r : kRows) {
    switch (k) {
      case 0: append(s, r.a, false); break;
      case 1: append(s, r.b, false); break;
      case 2: append(s, r.c, false); break;
      case 3: append(s, r.d, false); break;
      case 4: append(s, r.e, false); break;
      case 5: append(s, r.f, false); break;
      case 6: append(s, r.g, false); break;
      default: append(s, r.h, false); break;
    }
  }
  return std::vector<uint8_t>(s.begin(), s.end());
}

void check_contents(const PlyFile& ply) {
  ASSERT_EQ(ply.elements.size(), 2u);
  const PlyElement& v = ply.elements[0];
  ASSERT_EQ(v.name, "vertex");
  ASSERT_EQ(v.count, kRows.size());
  ASSERT_EQ(v.properties.size(), 9u);
  const PlyType types[] = {PlyType::Int8,  PlyType::UInt8,  PlyType::Int16,   PlyType::UInt16,
                           PlyType::Int32, PlyType::UInt32, PlyType::Float32, PlyType::Float64};
  for (int k = 0; k < 8; ++k) {
    EXPECT_EQ(v.properties[k].type, types[k]);
    EXPECT_EQ(v.properties[k].data, expected_column(k)) << "property " << v.properties[k].name;
  }
  const PlyProperty& idx = v.properties[8];
  ASSERT_TRUE(idx.is_list);
  EXPECT_EQ(idx.count_type, PlyType::UInt8);
  EXPECT_EQ(idx.type, PlyType::Int32);
  std::vector<uint64_t> offsets = {0};
  std::string items;
  for (const Row& r : kRows) {
    offsets.push_back(offsets.back() + r.list.size());
    for (int32_t x : r.list) append(items, x, false);
  }
  EXPECT_EQ(idx.list_offsets, offsets);
  EXPECT_EQ(idx.list_data, std::vector<uint8_t>(items.begin(), items.end()));
  const PlyElement& e = ply.elements[1];
  EXPECT_EQ(e.name, "extra");
  EXPECT_EQ(e.column_as_float("w", "x"), std::vector<float>(kExtra, kExtra + 2));
  ASSERT_EQ(ply.comments.size(), 1u);
  EXPECT_EQ(ply.comments[0], "hello world");
  ASSERT_EQ(ply.obj_info.size(), 1u);
  EXPECT_EQ(ply.obj_info[0], "made by hand");
}

}  // namespace

// Each input format reads to the same columns; write -> read is bit-exact; write -> read -> write gives identical
// bytes.
TEST(PlyIo, RoundTripAllTypesAllFormats) {
  const std::pair<std::string, std::string> inputs[] = {
      {"rt_ascii.ply", ascii_file()}, {"rt_le.ply", binary_file(false)}, {"rt_be.ply", binary_file(true)}};
  for (const auto& [name, contents] : inputs) {
    SCOPED_TRACE(name);
    const std::string in = ply_tmp(name), out1 = ply_tmp("out1_" + name), out2 = ply_tmp("out2_" + name);
    put_file(in, contents);
    const PlyFile a = read_ply(in);
    check_contents(a);
    write_ply(out1, a);
    const PlyFile b = read_ply(out1);
    EXPECT_EQ(b.format, PlyFormat::BinaryLittleEndian);
    check_contents(b);
    write_ply(out2, b);
    EXPECT_EQ(get_file(out1), get_file(out2));
    EXPECT_FALSE(std::filesystem::exists(atomic_temp_path(out1)));
  }
  // Little-endian input written back is byte-identical to the hand-made file apart from the header.
  const std::string le = binary_file(false), written = get_file(ply_tmp("out1_rt_le.ply"));
  const size_t body_le = le.find("end_header\n") + 11, body_w = written.find("end_header\n") + 11;
  EXPECT_EQ(le.substr(body_le), written.substr(body_w));
}

TEST(PlyIo, AccessorsAndSetFloatColumn) {
  const std::string in = ply_tmp("acc.ply");
  put_file(in, ascii_file());
  PlyFile ply = read_ply(in);
  PlyElement& v = *ply.get("vertex");
  EXPECT_EQ(ply.find("extra"), 1);
  EXPECT_EQ(ply.get("nope"), nullptr);
  EXPECT_EQ(v.find("c"), 2);
  EXPECT_DOUBLE_EQ(v.get("a")->as_double(0), -128.0);
  EXPECT_DOUBLE_EQ(v.get("f")->as_double(0), 4294967295.0);
  EXPECT_DOUBLE_EQ(v.get("h")->as_double(2), 2.5e300);
  v.set_float_column("c", {1, 2, 3});  // replaces the short column
  EXPECT_EQ(v.get("c")->type, PlyType::Float32);
  v.set_float_column("new", {4, 5, 6});  // appended
  EXPECT_EQ(v.properties.back().name, "new");
  EXPECT_EQ(v.column_as_float("c", in), (std::vector<float>{1, 2, 3}));
  test::expect_error([&] { v.column_as_float("missing", in); }, in, {"no property 'missing'"});
  test::expect_error([&] { v.column_as_float("idx", in); }, in, {"is a list"});
}

TEST(PlyIo, HeaderErrors) {
  expect_bad_ply("magic.ply", "plx\nformat ascii 1.0\nend_header\n", {"missing the 'ply' magic"});
  expect_bad_ply("empty.ply", "", {"not a PLY file"});
  expect_bad_ply("format.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n",
                 {"unsupported format 'binary_middle_endian'"});
  expect_bad_ply("version.ply", "ply\nformat ascii 2.0\nend_header\n", {"unsupported PLY version '2.0'"});
  expect_bad_ply("type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n1\n",
                 {"unknown property type 'float128'"});
  expect_bad_ply("listtype.ply", "ply\nformat ascii 1.0\nelement f 1\nproperty list uchar quad v\nend_header\n",
                 {"unknown property type 'quad'"});
  expect_bad_ply("order.ply", "ply\nformat ascii 1.0\nproperty float x\nelement vertex 1\nend_header\n1\n",
                 {"property before any element"});
  expect_bad_ply("noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", {"missing end_header"});
  expect_bad_ply("count.ply", "ply\nformat ascii 1.0\nelement vertex -3\nproperty float x\nend_header\n",
                 {"bad element count '-3'"});
}

TEST(PlyIo, BinaryBodyErrors) {
  const std::string xyz =
      "ply\nformat binary_little_endian 1.0\nelement vertex 10\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n";
  expect_bad_ply("trunc.ply", xyz + std::string(50, '\0'),
                 {"truncated: element 'vertex' needs 120 bytes, file has 50"});
  expect_bad_ply("extra.ply", xyz + std::string(124, '\0'),
                 {"count mismatch: 4 bytes of extra data after the last element 'vertex'"});
  expect_bad_ply("huge.ply",
                 "ply\nformat binary_little_endian 1.0\nelement vertex 18446744073709551615\nproperty double x\n"
                 "end_header\n" +
                     std::string(16, '\0'),
                 {"truncated", "more than 2^64"});
  const std::string faces =
      "ply\nformat binary_little_endian 1.0\nelement face 1\nproperty list char int v\nend_header\n";
  expect_bad_ply("negative.ply", faces + std::string(1, '\xff') + std::string(12, '\0'), {"negative list count -1"});
  const std::string ufaces =
      "ply\nformat binary_big_endian 1.0\nelement face 2\nproperty list uint int v\nend_header\n";
  expect_bad_ply("absurd.ply", ufaces + std::string(4, '\xff') + std::string(8, '\0'),
                 {"truncated: list count 4294967295"});
  expect_bad_ply("cutrow.ply", faces + std::string(1, '\x02') + std::string(4, '\0'), {"truncated"});
}

TEST(PlyIo, AsciiBodyErrors) {
  const std::string h = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty uchar c\nend_header\n";
  expect_bad_ply("rows.ply", h + "1 2\n3 4\n", {"count mismatch: header declares 3 'vertex' rows, file has 2"});
  expect_bad_ply("values.ply", h + "1 2\n3\n5 6\n", {"too few values", "row 1", "line 8", "property 'c'"});
  expect_bad_ply("many.ply", h + "1 2\n3 4 5\n5 6\n", {"too many values", "row 1"});
  expect_bad_ply("nonnum.ply", h + "1 2\nabc 4\n5 6\n", {"non-numeric value 'abc'", "property 'x'"});
  expect_bad_ply("range.ply", h + "1 2\n3 256\n5 6\n", {"out of range for uchar"});
  expect_bad_ply("trailing.ply", h + "1 2\n3 4\n5 6\n7 8\n", {"count mismatch", "extra data"});
  expect_bad_ply("hugeascii.ply",
                 "ply\nformat ascii 1.0\nelement vertex 18446744073709551615\nproperty float x\nend_header\n1\n",
                 {"count mismatch"});
  // Whitespace at the end and integers written as "3.0" are fine.
  const std::string ok = ply_tmp("ok_ascii.ply");
  put_file(ok, h + "1 2\n  3 4.0 \r\n5 +6\n\n  \n");
  const PlyFile ply = read_ply(ok);
  EXPECT_EQ(ply.elements[0].column_as_float("c", ok), (std::vector<float>{2, 4, 6}));
}

// A file cut anywhere inside its header says so. (A cut in the middle of a name
// such as f_rest_12 leaves "f_rest_1", which an earlier line already declared:
// it used to be reported as a duplicate property.)
TEST(PlyIo, HeaderCutAnywhereIsTruncated) {
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment made by a trainer\nelement vertex 2\n";
  for (const char* name : {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"})
    header += std::string("property float ") + name + "\n";
  for (int i = 0; i < 45; ++i) header += "property float f_rest_" + std::to_string(i) + "\n";
  header += "property float opacity\nend_header\n";
  const size_t end = header.find("end_header");
  const std::string path = ply_tmp("cut_header.ply");
  for (size_t cut = 4; cut < end; ++cut) {
    SCOPED_TRACE(header.substr(0, cut).substr(cut > 40 ? cut - 40 : 0));
    put_file(path, header.substr(0, cut));
    try {
      read_ply(path);
      ADD_FAILURE() << "no error for a header cut at byte " << cut;
    } catch (const ptir::Error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(path), std::string::npos) << msg;
      EXPECT_NE(msg.find("truncated"), std::string::npos) << msg;
      EXPECT_EQ(msg.find("duplicate"), std::string::npos) << msg;
    }
  }
  // The case a user met: the cut falls inside "f_rest_12".
  const std::string cut = header.substr(0, header.find("f_rest_12") + std::string("f_rest_1").size());
  put_file(path, cut);
  test::expect_error([&] { read_ply(path); }, path,
                     {"truncated", "in the middle of the line 'property float f_rest_1'"});
  // A whole header whose end_header has no line break is still a header.
  put_file(path, "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nend_header");
  EXPECT_EQ(read_ply(path).elements.at(0).count, 0u);
}

TEST(PlyIo, MissingFileAndWriteFailure) {
  const std::string missing = ply_tmp("does_not_exist.ply");
  test::expect_error([&] { read_ply(missing); }, missing, {"cannot open file", "No such file"});
  PlyFile ply;
  ply.elements.push_back({"vertex", 1, {}});
  ply.elements[0].set_float_column("x", {1.0f});
  const std::string bad = ply_tmp("no_such_dir/out.ply");
  test::expect_error([&] { write_ply(bad, ply); }, bad, {"cannot write file"});
  // A column with the wrong size is refused before anything is written.
  ply.elements[0].properties[0].data.resize(3);
  const std::string shape = ply_tmp("shape.ply");
  test::expect_error([&] { write_ply(shape, ply); }, shape, {"property 'x'", "bytes"});
  EXPECT_FALSE(std::filesystem::exists(shape));
  // A failure part-way (a list too long for its count type) keeps the old file and leaves no temp.
  PlyFile lists;
  lists.elements.push_back({"face", 1, {}});
  PlyProperty list;
  list.name = "vertex_indices";
  list.is_list = true;
  list.count_type = PlyType::UInt8;
  list.type = PlyType::Int32;
  list.list_offsets = {0, 300};
  list.list_data.assign(300 * 4, 0);
  lists.elements[0].properties.push_back(list);
  const std::string kept = ply_tmp("kept.ply");
  put_file(kept, "old contents");
  test::expect_error([&] { write_ply(kept, lists); }, kept, {"300 items", "too many"});
  EXPECT_EQ(get_file(kept), "old contents");
  for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::path(kept).parent_path()))
    EXPECT_EQ(entry.path().filename().string().find(".ptir-tmp-"), std::string::npos) << entry.path();
}
