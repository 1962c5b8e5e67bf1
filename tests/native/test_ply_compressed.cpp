// SuperSplat compressed PLY: a tiny file written by an independent encoder of the
// documented layout (PlayCanvas compressed-ply) decodes to the original values
// within quantisation tolerance; saving writes the decoded standard layout.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <initializer_list>

#include "ptir/core/error.h"
#include "ptir/io/ply.h"
#include "ptir/scene/gaussian_ply.h"

using namespace ptir;

namespace {

constexpr double kShC0 = 0.28209479177387814;

std::string cmp_tmp(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(PTIR_TEST_TMP) / "ply_compressed";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

}  // namespace

namespace {

uint32_t quantise(double t, int bits) {
  const double max = (1u << bits) - 1;
  return static_cast<uint32_t>(std::lround(std::min(std::max(t, 0.0), 1.0) * max));
}

struct Splat {
  double pos[3], log_scale[3], quat[4], dc[3], opacity_logit, rest[9];
};

Splat test_splat(size_t i) {
  Splat s;
  const double t = static_cast<double>(i);
  for (int k = 0; k < 3; ++k) {
    s.pos[k] = 2.0 * std::sin(t * (k + 1) * 0.37) + k;
    s.log_scale[k] = -3.0 + std::cos(t * 0.11 * (k + 1));
    s.dc[k] = 0.9 * std::sin(t * 0.05 + k);
  }
  double q[4] = {std::cos(t), std::sin(t * 1.3), std::cos(t * 0.7) - 0.2, std::sin(t * 2.1) + 0.1}, len = 0;
  for (double c : q) len += c * c;
  for (int k = 0; k < 4; ++k) s.quat[k] = q[k] / std::sqrt(len);
  s.opacity_logit = 3.0 * std::sin(t * 0.3);
  for (int j = 0; j < 9; ++j) s.rest[j] = 0.8 * std::sin(t * 0.2 + j);
  return s;
}

// Smallest three: index of the largest |component| (w,x,y,z order), the other three as 10-bit unorm of v/sqrt2 + 0.5.
uint32_t pack_rotation(const double q_in[4]) {
  int largest = 0;
  for (int k = 1; k < 4; ++k)
    if (std::fabs(q_in[k]) > std::fabs(q_in[largest])) largest = k;
  const double sign = q_in[largest] < 0 ? -1.0 : 1.0;
  uint32_t word = static_cast<uint32_t>(largest) << 30;
  int shift = 20;
  for (int k = 0; k < 4; ++k) {
    if (k == largest) continue;
    word |= quantise(sign * q_in[k] / std::sqrt(2.0) + 0.5, 10) << shift;
    shift -= 10;
  }
  return word;
}

std::string write_compressed(const std::string& name, size_t n, bool colour_bounds, size_t chunks) {
  io::PlyFile ply;
  io::PlyElement chunk{"chunk", chunks, {}}, vertex{"vertex", n, {}}, sh{"sh", n, {}};
  const char* bound_names[6] = {"x", "y", "z", "scale_x", "scale_y", "scale_z"};
  // `chunks` may be fewer than the splats need (to test the error): bounds cover them all.
  const size_t needed = (n + 255) / 256;
  std::vector<std::vector<float>> bounds(18, std::vector<float>(std::max(chunks, needed), 0.0f));
  std::vector<Splat> splats;
  for (size_t i = 0; i < n; ++i) splats.push_back(test_splat(i));
  // Per chunk bounds: position, log scale, colour.
  for (size_t c = 0; c < needed; ++c) {
    for (int k = 0; k < 9; ++k) {
      bounds[k][c] = 1e30f;
      bounds[9 + k][c] = -1e30f;
    }
    for (size_t i = c * 256; i < std::min(n, (c + 1) * 256); ++i) {
      for (int k = 0; k < 3; ++k) {
        const double vals[3] = {splats[i].pos[k], splats[i].log_scale[k], 0.5 + kShC0 * splats[i].dc[k]};
        for (int g = 0; g < 3; ++g) {
          bounds[g * 3 + k][c] = std::min(bounds[g * 3 + k][c], static_cast<float>(vals[g]));
          bounds[9 + g * 3 + k][c] = std::max(bounds[9 + g * 3 + k][c], static_cast<float>(vals[g]));
        }
      }
    }
  }
  // Chunk element in the documented order: min xyz, max xyz, min scale, max scale, [min rgb, max rgb].
  const int order[18] = {0, 1, 2, 9, 10, 11, 3, 4, 5, 12, 13, 14, 6, 7, 8, 15, 16, 17};
  const char* colour_names[6] = {"min_r", "min_g", "min_b", "max_r", "max_g", "max_b"};
  for (int j = 0; j < (colour_bounds ? 18 : 12); ++j) {
    std::string pname =
        j < 12 ? std::string(j % 6 < 3 ? "min_" : "max_") + bound_names[(j / 6) * 3 + j % 3] : colour_names[j - 12];
    chunk.set_float_column(pname, std::vector<float>(bounds[order[j]].begin(), bounds[order[j]].begin() + chunks));
  }
  // Packed words and 8-bit SH.
  std::vector<std::vector<uint8_t>> rest(9);
  io::PlyProperty packed[4];
  const char* packed_names[4] = {"packed_position", "packed_rotation", "packed_scale", "packed_color"};
  for (size_t i = 0; i < n; ++i) {
    const size_t c = i / 256;
    const Splat& s = splats[i];
    auto unorm = [&](int g, int k, double v) {
      const double lo = bounds[g * 3 + k][c], hi = bounds[9 + g * 3 + k][c];
      return hi > lo ? (v - lo) / (hi - lo) : 0.0;
    };
    uint32_t w[4];
    w[0] = quantise(unorm(0, 0, s.pos[0]), 11) << 21 | quantise(unorm(0, 1, s.pos[1]), 10) << 11 |
           quantise(unorm(0, 2, s.pos[2]), 11);
    w[1] = pack_rotation(s.quat);
    w[2] = quantise(unorm(1, 0, s.log_scale[0]), 11) << 21 | quantise(unorm(1, 1, s.log_scale[1]), 10) << 11 |
           quantise(unorm(1, 2, s.log_scale[2]), 11);
    w[3] = quantise(1.0 / (1.0 + std::exp(-s.opacity_logit)), 8);
    for (int k = 0; k < 3; ++k) {
      const double colour = 0.5 + kShC0 * s.dc[k];
      w[3] |= quantise(colour_bounds ? unorm(2, k, colour) : colour, 8) << (24 - 8 * k);
    }
    for (int p = 0; p < 4; ++p) {
      const uint8_t* b = reinterpret_cast<const uint8_t*>(&w[p]);
      packed[p].data.insert(packed[p].data.end(), b, b + 4);
    }
    for (int j = 0; j < 9; ++j)
      rest[j].push_back(static_cast<uint8_t>(std::min(255.0, std::max(0.0, std::trunc((s.rest[j] / 8 + 0.5) * 256)))));
  }
  for (int p = 0; p < 4; ++p) {
    packed[p].name = packed_names[p];
    packed[p].type = io::PlyType::UInt32;
    vertex.properties.push_back(packed[p]);
  }
  for (int j = 0; j < 9; ++j) {
    io::PlyProperty prop;
    prop.name = "f_rest_" + std::to_string(j);
    prop.type = io::PlyType::UInt8;
    prop.data = rest[j];
    sh.properties.push_back(prop);
  }
  ply.elements = {chunk, vertex, sh};
  const std::string path = cmp_tmp(name);
  io::write_ply(path, ply);
  return path;
}

void check_compressed(const std::string& path, size_t n, bool colour_bounds) {
  const GaussianField f = load_gaussians(path);
  ASSERT_EQ(f.size(), n);
  ASSERT_EQ(f.sh_degree, 1);
  std::vector<Splat> splats;
  for (size_t i = 0; i < n; ++i) splats.push_back(test_splat(i));
  const int bits[3] = {11, 10, 11};
  for (size_t c0 = 0; c0 < n; c0 += 256) {
    const size_t c1 = std::min(n, c0 + 256);
    // Chunk ranges: the tolerance is half a quantisation step of each range.
    double lo[3][3], hi[3][3];  // [position, log scale, dc][axis]
    for (int g = 0; g < 3; ++g)
      for (int k = 0; k < 3; ++k) {
        lo[g][k] = 1e30;
        hi[g][k] = -1e30;
      }
    for (size_t i = c0; i < c1; ++i)
      for (int k = 0; k < 3; ++k) {
        const double vals[3] = {splats[i].pos[k], splats[i].log_scale[k], splats[i].dc[k]};
        for (int g = 0; g < 3; ++g) {
          lo[g][k] = std::min(lo[g][k], vals[g]);
          hi[g][k] = std::max(hi[g][k], vals[g]);
        }
      }
    for (size_t i = c0; i < c1; ++i) {
      const Splat& s = splats[i];
      for (int k = 0; k < 3; ++k) {
        const double steps = (1 << bits[k]) - 1;
        EXPECT_NEAR(f.position[i][k], s.pos[k], 0.5 * (hi[0][k] - lo[0][k]) / steps + 1e-5) << i;
        EXPECT_NEAR(std::log(f.scale[i][k]), s.log_scale[k], 0.5 * (hi[1][k] - lo[1][k]) / steps + 1e-5) << i;
        const double dc_tol = colour_bounds ? 0.5 * (hi[2][k] - lo[2][k]) / 255 : 0.5 / 255 / kShC0;
        EXPECT_NEAR(f.sh[i * 12 + k], s.dc[k], dc_tol + 1e-5) << i;
      }
      double d = 0;
      for (int k = 0; k < 4; ++k) d += f.rotation[i][k] * s.quat[k];
      EXPECT_GT(std::fabs(d), 0.9995) << i;
      EXPECT_NEAR(f.opacity[i], 1.0 / (1.0 + std::exp(-s.opacity_logit)), 0.5 / 255 + 1e-5) << i;
      for (int j = 0; j < 9; ++j) {
        const int c = j / 3, k = 1 + j % 3;  // f_rest_j is channel c, coefficient k
        EXPECT_NEAR(f.sh[i * 12 + k * 3 + c], s.rest[j], 1.0 / 64 + 1e-5) << i;
      }
    }
  }
}

}  // namespace

TEST(PlyCompressed, SuperSplatDecodes) {
  check_compressed(write_compressed("compressed.ply", 300, true, 2), 300, true);
  check_compressed(write_compressed("compressed_old.ply", 40, false, 1), 40, false);
  // Saving a compressed input writes the decoded standard layout.
  const std::string out = cmp_tmp("compressed_saved.ply");
  save_gaussians(out, load_gaussians(cmp_tmp("compressed.ply")));
  const io::PlyFile saved = io::read_ply(out);
  EXPECT_EQ(saved.get("chunk"), nullptr);
  EXPECT_EQ(saved.get("vertex")->get("packed_position"), nullptr);
  EXPECT_NE(saved.get("vertex")->get("f_rest_8"), nullptr);
  check_compressed(out, 300, true);
}

TEST(PlyCompressed, SuperSplatErrors) {
  const std::string path = write_compressed("compressed_short.ply", 300, true, 1);
  try {
    load_gaussians(path);
    ADD_FAILURE() << "no error";
  } catch (const ptir::Error& e) {
    const std::string msg = e.what();
    for (const std::string& p : {path, std::string("compressed splat PLY"), std::string("300 splats need 2 chunks")})
      EXPECT_NE(msg.find(p), std::string::npos) << msg;
  }
}
