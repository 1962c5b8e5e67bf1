// 3DGS PLY loading/saving: activations, SH layout, materials and normals,
// bad-input messages, SuperSplat compressed decoding, bit-exact saving.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>

#include "ptir/core/error.h"
#include "ptir/io/ply.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/gaussians.h"
#include "expect_error.h"

using namespace ptir;

namespace {

constexpr double kC0 = 0.28209479177387814;
constexpr double kC1 = 0.4886025119029199;

std::string gs_tmp(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(PTIR_TEST_TMP) / "gaussian_ply";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

// ASCII PLY with one "vertex" element; props are "type name", rows are whole lines.
std::string write_ascii(const std::string& name, const std::vector<std::string>& props,
                        const std::vector<std::string>& rows) {
  const std::string path = gs_tmp(name);
  std::ofstream f(path, std::ios::binary);
  f << "ply\nformat ascii 1.0\nelement vertex " << rows.size() << "\n";
  for (const std::string& p : props) f << "property " << p << "\n";
  f << "end_header\n";
  for (const std::string& r : rows) f << r << "\n";
  return path;
}

std::vector<std::string> float_props(std::initializer_list<std::string> names) {
  std::vector<std::string> out;
  for (const std::string& n : names) out.push_back("float " + n);
  return out;
}

const std::vector<std::string> kBasic =
    float_props({"x", "y", "z", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3", "opacity"});
const std::string kBasicRow = "0 0 0 0 0 0 1 0 0 0 0";

void expect_load_error(const std::string& path, std::initializer_list<std::string> phrases) {
  test::expect_error([&] { load_gaussians(path); }, path, phrases);
}

}  // namespace

TEST(GaussianPly, ActivationsAndDefaults) {
  std::vector<std::string> props = kBasic;
  props[0] = "double x";  // any numeric type is accepted
  const std::string path = write_ascii("act.ply", props,
                                       {"1 2 3 " + num(std::log(0.5)) + " " + num(std::log(2.0)) + " 0 2 0 0 0 0",
                                        "-1 0 4 0 0 " + num(std::log(0.1)) + " 1 1 1 1 2"});
  const GaussianField f = load_gaussians(path);
  ASSERT_EQ(f.size(), 2u);
  EXPECT_EQ(f.source_path, path);
  EXPECT_FLOAT_EQ(f.position[0].x, 1.0f);
  EXPECT_FLOAT_EQ(f.position[1].z, 4.0f);
  EXPECT_NEAR(f.scale[0].x, 0.5f, 1e-6);
  EXPECT_NEAR(f.scale[0].y, 2.0f, 1e-6);
  EXPECT_NEAR(f.scale[0].z, 1.0f, 1e-6);
  EXPECT_NEAR(f.scale[1].z, 0.1f, 1e-6);
  EXPECT_FLOAT_EQ(f.rotation[0][0], 1.0f);
  for (int k = 0; k < 4; ++k) EXPECT_FLOAT_EQ(f.rotation[1][k], 0.5f);
  EXPECT_FLOAT_EQ(f.opacity[0], 0.5f);
  EXPECT_NEAR(f.opacity[1], 1.0 / (1.0 + std::exp(-2.0)), 1e-6);
  // No f_dc: degree 0, zero DC, grey preview.
  EXPECT_EQ(f.sh_degree, 0);
  EXPECT_EQ(f.sh.size(), 6u);
  EXPECT_FLOAT_EQ(f.sh_colour(0, Vec3(0, 0, 1)).y, 0.5f);
  // Material defaults; normals are the shortest axis (z for Gaussian 0).
  EXPECT_FLOAT_EQ(f.albedo[1].z, kDefaultAlbedo);
  EXPECT_FLOAT_EQ(f.roughness[0], kDefaultRoughness);
  EXPECT_FLOAT_EQ(f.metallic[0], kDefaultMetallic);
  EXPECT_FALSE(f.normals_from_file);
  EXPECT_NEAR(std::fabs(f.normal[0].x), 1.0f, 1e-6);  // scale (0.5, 2, 1): x is shortest
  EXPECT_EQ(f.source.get("vertex")->count, 2u);
}

TEST(GaussianPly, ShChannelMajorLayoutAndColour) {
  std::vector<std::string> props = kBasic;
  for (const char* n : {"f_dc_0", "f_dc_1", "f_dc_2"}) props.push_back(std::string("float ") + n);
  for (int j = 0; j < 9; ++j) props.push_back("float f_rest_" + std::to_string(j));
  std::string distinct = kBasicRow + " 1 2 3", small = kBasicRow + " 0.1 0.2 0.3";
  for (int j = 0; j < 9; ++j) {
    distinct += " " + std::to_string(10 + j);
    small += " " + num(0.01 * (j + 1));
  }
  const GaussianField f =
      load_gaussians(write_ascii("sh1.ply", props, {distinct, small, kBasicRow + " -5 -5 -5 0 0 0 0 0 0 0 0 0"}));
  ASSERT_EQ(f.sh_degree, 1);
  ASSERT_EQ(f.sh_stride(), 12);
  // sh[k*3 + c]: k = 0 is f_dc_c, k >= 1 is f_rest_[c*3 + k-1].
  for (int c = 0; c < 3; ++c) {
    EXPECT_FLOAT_EQ(f.sh[c], 1.0f + c);
    for (int k = 1; k <= 3; ++k) EXPECT_FLOAT_EQ(f.sh[k * 3 + c], 10.0f + c * 3 + (k - 1)) << "c=" << c << " k=" << k;
  }
  // Degree-1 colour by hand: 0.5 + C0*dc - C1*y*r0 + C1*z*r1 - C1*x*r2 (per channel), dir normalised.
  const Vec3 dir(1, 2, 2);
  const double x = 1.0 / 3, y = 2.0 / 3, z = 2.0 / 3;
  const Vec3 col = f.sh_colour(1, dir);
  for (int c = 0; c < 3; ++c) {
    const double dc = 0.1 * (c + 1), r0 = 0.01 * (c * 3 + 1), r1 = 0.01 * (c * 3 + 2), r2 = 0.01 * (c * 3 + 3);
    const double expected = 0.5 + kC0 * dc - kC1 * y * r0 + kC1 * z * r1 - kC1 * x * r2;
    EXPECT_NEAR(col[c], expected, 1e-6) << "channel " << c;
  }
  EXPECT_FLOAT_EQ(f.sh_colour(2, dir).x, 0.0f);  // clamped at zero
}

TEST(GaussianPly, DegreeZeroColour) {
  std::vector<std::string> props = kBasic;
  for (const char* n : {"f_dc_0", "f_dc_1", "f_dc_2"}) props.push_back(std::string("float ") + n);
  const GaussianField f = load_gaussians(write_ascii("sh0.ply", props, {kBasicRow + " 0.1 -0.2 0.3"}));
  const Vec3 c = f.sh_colour(0, Vec3(0.3f, -0.4f, 0.5f));
  EXPECT_NEAR(c.x, 0.5 + kC0 * 0.1, 1e-6);
  EXPECT_NEAR(c.y, 0.5 - kC0 * 0.2, 1e-6);
  EXPECT_NEAR(c.z, 0.5 + kC0 * 0.3, 1e-6);
}

TEST(GaussianPly, MaterialsAndFileNormals) {
  std::vector<std::string> props = kBasic;
  for (const char* n : {"albedo_0", "albedo_1", "albedo_2", "roughness", "metallic", "nx", "ny", "nz"})
    props.push_back(std::string("float ") + n);
  // Gaussian 0 has a file normal (normalised on load); Gaussian 1 has a zero normal -> shortest axis.
  const std::string path = write_ascii(
      "mat.ply", props,
      {"0 0 0 0 0 0 1 0 0 0 0 0.1 0.2 0.3 0.4 0.5 0 3 4", "0 0 0 0 0 -3 1 0 0 0 0 0.6 0.7 0.8 0.9 1 0 0 0"});
  const GaussianField f = load_gaussians(path);
  EXPECT_FLOAT_EQ(f.albedo[0].y, 0.2f);
  EXPECT_FLOAT_EQ(f.albedo[1].z, 0.8f);
  EXPECT_FLOAT_EQ(f.roughness[1], 0.9f);
  EXPECT_FLOAT_EQ(f.metallic[0], 0.5f);
  EXPECT_NEAR(f.normal[0].y, 0.6f, 1e-6);
  EXPECT_NEAR(f.normal[0].z, 0.8f, 1e-6);
  EXPECT_NEAR(std::fabs(f.normal[1].z), 1.0f, 1e-6);
  EXPECT_FALSE(f.normals_from_file);
  const GaussianField g =
      load_gaussians(write_ascii("mat2.ply", props, {"0 0 0 0 0 0 1 0 0 0 0 0.1 0.2 0.3 0.4 0.5 0 0 2"}));
  EXPECT_TRUE(g.normals_from_file);
}

TEST(GaussianPly, BadInputMessages) {
  expect_load_error(write_ascii("pointcloud.ply", {"float x", "float y", "float z", "uchar red"}, {"0 0 0 1"}),
                    {"not a 3D Gaussian splat PLY: missing properties scale_0, scale_1, scale_2, rot_0, rot_1, rot_2, "
                     "rot_3, opacity",
                     "plain point cloud"});
  std::vector<std::string> partial = kBasic;
  partial.erase(partial.begin() + 4);  // scale_1
  expect_load_error(write_ascii("partial.ply", partial, {"0 0 0 0 0 1 0 0 0 0"}), {"missing properties scale_1 ("});
  expect_load_error(write_ascii("nan.ply", kBasic, {kBasicRow, "0 0 0 0 nan 0 1 0 0 0 0"}),
                    {"property 'scale_1' is NaN at vertex 1"});
  expect_load_error(write_ascii("inf.ply", kBasic, {kBasicRow, kBasicRow, "0 0 0 0 0 0 1 0 0 0 -inf"}),
                    {"property 'opacity' is infinite at vertex 2"});
  expect_load_error(write_ascii("quat.ply", kBasic, {kBasicRow, "0 0 0 0 0 0 0 0 0 0 0"}),
                    {"zero-length rotation quaternion", "vertex 1"});
  std::vector<std::string> rest6 = kBasic;
  for (int j = 0; j < 6; ++j) rest6.push_back("float f_rest_" + std::to_string(j));
  expect_load_error(write_ascii("rest6.ply", rest6, {kBasicRow + " 0 0 0 0 0 0"}),
                    {"unsupported SH: 6 f_rest_* properties", "0, 9, 24, 45 or 72"});
  expect_load_error(write_ascii("empty.ply", kBasic, {}), {"contains no Gaussians"});
  expect_load_error(gs_tmp("missing_file.ply"), {"cannot open file"});
  expect_load_error(write_ascii("huge.ply", kBasic, {"0 0 0 1000 0 0 1 0 0 0 0"}), {"scale_0", "too large"});
}

// 2D Gaussian Splatting writes surfels: scale_0 and scale_1 only (its save_ply), normals
// zero. They load as flat Gaussians, kSurfelThickness x the smaller scale thick, whose
// normal is the rotation's z axis; saved, the file keeps its two scale columns.
TEST(GaussianPly, SurfelsOf2dgs) {
  const std::vector<std::string> props = float_props({"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2",
                                                      "opacity", "scale_0", "scale_1", "rot_0", "rot_1", "rot_2", "rot_3"});
  const double h = std::sqrt(0.5);  // a quarter turn about x: the surfel's z axis goes to -y
  const std::string in = write_ascii(
      "surfels.ply", props,
      {"0 0 0 0 0 0 0.1 0.2 0.3 0 " + num(std::log(0.2)) + " " + num(std::log(0.05)) + " 1 0 0 0",
       "1 0 0 0 0 0 0 0 0 2 " + num(std::log(0.03)) + " " + num(std::log(0.04)) + " " + num(h) + " " + num(h) + " 0 0"});
  GaussianField f = load_gaussians(in);
  ASSERT_EQ(f.size(), 2u);
  EXPECT_NEAR(f.scale[0].x, 0.2f, 1e-6);
  EXPECT_NEAR(f.scale[0].y, 0.05f, 1e-6);
  EXPECT_FLOAT_EQ(f.scale[0].z, kSurfelThickness * f.scale[0].y);
  EXPECT_FLOAT_EQ(f.scale[1].z, kSurfelThickness * f.scale[1].x);
  EXPECT_FALSE(f.normals_from_file);  // zero nx, ny, nz: the shortest axis, i.e. the surfel's normal
  EXPECT_NEAR(std::fabs(f.normal[0].z), 1.0f, 1e-6);
  EXPECT_NEAR(std::fabs(f.normal[1].y), 1.0f, 1e-6);

  const std::string out = gs_tmp("surfels_out.ply");
  save_gaussians(out, f);
  const io::PlyFile b = io::read_ply(out);
  EXPECT_EQ(b.get("vertex")->get("scale_2"), nullptr);
  const GaussianField g = load_gaussians(out);
  for (size_t i = 0; i < 2; ++i)
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(g.scale[i][k], f.scale[i][k]);

  // One scale alone is not a surfel: both missing ones are named.
  expect_load_error(write_ascii("one_scale.ply", float_props({"x", "y", "z", "scale_0", "rot_0", "rot_1", "rot_2",
                                                              "rot_3", "opacity"}),
                                {"0 0 0 0 1 0 0 0 0"}),
                    {"missing properties scale_1, scale_2 ("});
}

TEST(GaussianPly, ShortestAxisAndCentroidOrientation) {
  GaussianField f;
  const float s = std::sqrt(0.5f);
  f.position = {Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(0, 3, 0)};
  f.scale = {Vec3(1, 1, 0.1f), Vec3(1, 1, 0.1f), Vec3(1, 1, 0.1f)};
  f.rotation = {{1, 0, 0, 0}, {1, 0, 0, 0}, {s, s, 0, 0}};  // the third: 90 degrees about x, local z -> world -y
  f.opacity = {1, 1, 1};
  init_normals_shortest_axis(f);
  EXPECT_NEAR(std::fabs(f.normal[0].z), 1.0f, 1e-6);
  EXPECT_NEAR(f.normal[2].y, -1.0f, 1e-6);
  // Centroid is (0, 1, 0): the third normal (-y) points toward it and flips; the mask skips Gaussian 1.
  f.normal[0] = Vec3(0, 0, -1);
  f.normal[1] = Vec3(0, 0, 1);
  const std::vector<uint8_t> mask = {1, 0, 1};
  orient_normals_away_from_centroid(f, &mask);
  EXPECT_FLOAT_EQ(f.normal[0].z, 1.0f);
  EXPECT_FLOAT_EQ(f.normal[1].z, 1.0f);  // untouched
  EXPECT_NEAR(f.normal[2].y, 1.0f, 1e-6);
  orient_normals_away_from_centroid(f);
  EXPECT_FLOAT_EQ(f.normal[1].z, -1.0f);
}

namespace {

// A binary splat file with degree-3 SH, a double and a uchar extra property.
io::PlyFile make_splat_ply(size_t n) {
  io::PlyFile ply;
  ply.comments = {"trained by somebody"};
  io::PlyElement v;
  v.name = "vertex";
  v.count = n;
  std::vector<float> col(n);
  auto put = [&](const std::string& name, auto&& fn) {
    for (size_t i = 0; i < n; ++i) col[i] = static_cast<float>(fn(static_cast<double>(i)));
    v.set_float_column(name, col);
  };
  put("x", [](double i) { return std::sin(i); });
  put("y", [](double i) { return std::cos(i * 0.7); });
  put("z", [](double i) { return 0.01 * i; });
  for (int c = 0; c < 3; ++c) put("f_dc_" + std::to_string(c), [c](double i) { return 0.1 * c - 0.01 * i; });
  for (int j = 0; j < 45; ++j) put("f_rest_" + std::to_string(j), [j](double i) { return 0.001 * j + 1e-5 * i; });
  put("opacity", [](double i) { return std::fmod(i, 7.0) - 3.0; });
  for (int k = 0; k < 3; ++k) put("scale_" + std::to_string(k), [k](double i) { return -4.0 + k + 0.001 * i; });
  for (int k = 0; k < 4; ++k) put("rot_" + std::to_string(k), [k](double i) { return k == 0 ? 1.0 + i : 0.1 * k; });
  io::PlyProperty extra_d;
  extra_d.name = "my_double";
  extra_d.type = io::PlyType::Float64;
  io::PlyProperty extra_u;
  extra_u.name = "my_flag";
  extra_u.type = io::PlyType::UInt8;
  for (size_t i = 0; i < n; ++i) {
    const double d = 1.0 / 3.0 + static_cast<double>(i);
    const uint8_t* b = reinterpret_cast<const uint8_t*>(&d);
    extra_d.data.insert(extra_d.data.end(), b, b + 8);
    extra_u.data.push_back(static_cast<uint8_t>(i * 37));
  }
  v.properties.push_back(extra_d);
  v.properties.push_back(extra_u);
  ply.elements.push_back(std::move(v));
  return ply;
}

}  // namespace

TEST(GaussianPly, SaveKeepsInputBitExactAndAddsMaterials) {
  const std::string in = gs_tmp("deg3_in.ply"), out = gs_tmp("deg3_out.ply");
  io::write_ply(in, make_splat_ply(5));
  GaussianField f = load_gaussians(in);
  ASSERT_EQ(f.sh_degree, 3);
  EXPECT_FLOAT_EQ(f.sh[2 * 48 + 5 * 3 + 1], 0.001f * (15 + 4) + 2e-5f);  // k=5, c=1 -> f_rest_[1*15 + 4], Gaussian 2
  for (size_t i = 0; i < f.size(); ++i) {
    f.albedo[i] = Vec3(0.1f * i, 0.2f, 0.3f);
    f.roughness[i] = 0.05f * i;
    f.metallic[i] = 0.5f;
  }
  save_gaussians(out, f);

  const io::PlyFile a = io::read_ply(in), b = io::read_ply(out);
  const io::PlyElement &va = *a.get("vertex"), &vb = *b.get("vertex");
  ASSERT_EQ(vb.properties.size(), va.properties.size() + 8);
  for (size_t k = 0; k < va.properties.size(); ++k) {
    EXPECT_EQ(vb.properties[k].name, va.properties[k].name);
    EXPECT_EQ(vb.properties[k].type, va.properties[k].type);
    EXPECT_EQ(vb.properties[k].data, va.properties[k].data) << va.properties[k].name;
  }
  EXPECT_EQ(b.comments, a.comments);
  for (const char* name : {"albedo_0", "albedo_1", "albedo_2", "roughness", "metallic", "nx", "ny", "nz"}) {
    ASSERT_NE(vb.get(name), nullptr) << name;
    EXPECT_EQ(vb.get(name)->type, io::PlyType::Float32);
  }
  const GaussianField g = load_gaussians(out);
  EXPECT_TRUE(g.normals_from_file);
  for (size_t i = 0; i < g.size(); ++i) {
    EXPECT_FLOAT_EQ(g.albedo[i].x, f.albedo[i].x);
    EXPECT_FLOAT_EQ(g.roughness[i], f.roughness[i]);
    EXPECT_FLOAT_EQ(g.metallic[i], 0.5f);
    EXPECT_NEAR(dot(g.normal[i], f.normal[i]), 1.0f, 1e-6);
  }
}

TEST(GaussianPly, SaveFieldBuiltInCode) {
  GaussianField f;
  f.position = {Vec3(1, 2, 3), Vec3(-1, 0, 0)};
  f.scale = {Vec3(0.5f, 1, 2), Vec3(0.1f, 0.1f, 0.01f)};
  f.rotation = {{1, 0, 0, 0}, {0.5f, 0.5f, 0.5f, 0.5f}};
  f.opacity = {0.25f, 1.0f};  // 1.0 must not become an infinite logit
  f.sh_degree = 1;
  f.sh.resize(2 * 12);
  for (size_t j = 0; j < f.sh.size(); ++j) f.sh[j] = 0.01f * j;
  f.albedo = {Vec3(0.1f), Vec3(0.9f)};
  f.roughness = {0.2f, 0.7f};
  f.metallic = {0.0f, 1.0f};
  init_normals_shortest_axis(f);
  const std::string path = gs_tmp("from_code.ply");
  save_gaussians(path, f);
  const GaussianField g = load_gaussians(path);
  ASSERT_EQ(g.size(), 2u);
  EXPECT_EQ(g.sh_degree, 1);
  for (size_t j = 0; j < f.sh.size(); ++j) EXPECT_FLOAT_EQ(g.sh[j], f.sh[j]);
  EXPECT_NEAR(g.scale[1].z, 0.01f, 1e-7);
  EXPECT_NEAR(g.opacity[0], 0.25f, 1e-6);
  EXPECT_NEAR(g.opacity[1], 1.0f, 1e-6);
  EXPECT_NEAR(g.rotation[1][3], 0.5f, 1e-6);
  EXPECT_FLOAT_EQ(g.albedo[1].y, 0.9f);
  EXPECT_FLOAT_EQ(g.metallic[1], 1.0f);
  EXPECT_TRUE(g.normals_from_file);
}

// Throwaway timing of a 1M-Gaussian degree-3 file (62 float properties). Run with
// --gtest_also_run_disabled_tests; no assertion on the time.
TEST(GaussianPly, DISABLED_Load1MGaussiansTiming) {
  const size_t n = 1000000;
  io::PlyFile ply;
  ply.elements.push_back({"vertex", n, {}});
  io::PlyElement& v = ply.elements[0];
  std::vector<std::string> names = {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"};
  for (int j = 0; j < 45; ++j) names.push_back("f_rest_" + std::to_string(j));
  for (const char* s : {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"})
    names.push_back(s);
  ASSERT_EQ(names.size(), 62u);
  std::vector<float> col(n);
  for (size_t k = 0; k < names.size(); ++k) {
    for (size_t i = 0; i < n; ++i) col[i] = names[k] == "rot_0" ? 1.0f : 0.001f * static_cast<float>((i + k) % 1000);
    v.set_float_column(names[k], col);
  }
  const std::string path = gs_tmp("million.ply");
  io::write_ply(path, ply);
  ply = io::PlyFile();
  auto ms = [](auto a, auto b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
  for (int rep = 0; rep < 3; ++rep) {
    auto t0 = std::chrono::steady_clock::now();
    io::PlyFile raw = io::read_ply(path);
    auto t1 = std::chrono::steady_clock::now();
    const GaussianField f = gaussians_from_ply(std::move(raw), path);
    auto t2 = std::chrono::steady_clock::now();
    std::printf("1M Gaussians, 62 props, %.0f MB: read_ply %.0f ms + gaussians_from_ply %.0f ms = %.0f ms\n",
                std::filesystem::file_size(path) / 1e6, ms(t0, t1), ms(t1, t2), ms(t0, t2));
    EXPECT_EQ(f.size(), n);
    EXPECT_EQ(f.sh_degree, 3);
  }
  std::filesystem::remove(path);
}
