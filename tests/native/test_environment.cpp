// Environment lights: lat-long orientation (checked against Cycles), rotation,
// importance sampling (chi-square against the pdf), pdf normalisation
// and the spherical-Gaussian environment
// (lobe sampling, mixture pdf, analytic integrals, derivatives).
#include <gtest/gtest.h>


#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "ptir/core/error.h"
#include "ptir/io/image.h"
#include "ptir/lights/distribution.h"
#include "ptir/lights/env_sg.h"
#include "ptir/lights/environment.h"
#include "ptir/math/rng.h"
#include "chi2_test.h"

using namespace ptir;

namespace {

constexpr double kPiD = 3.14159265358979323846;

Vec3 dir_from_angles(double azimuth, double elevation) {
  return {float(std::cos(elevation) * std::cos(azimuth)), float(std::cos(elevation) * std::sin(azimuth)),
          float(std::sin(elevation))};
}

Vec3 rotate_z(Vec3 d, double a) {
  return {float(std::cos(a) * d.x - std::sin(a) * d.y), float(std::sin(a) * d.x + std::cos(a) * d.y), d.z};
}

// The "texel-coded" map of tests/blender/light_units_reference.py: texel (x, y),
// row 0 = top, has RGB ((x+.5)/W, (y+.5)/H, 0.25).
Image coded_map(int w = 16, int h = 8) {
  Image img(w, h, {"R", "G", "B"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      img.at(x, y, 0) = (x + 0.5f) / w;
      img.at(x, y, 1) = (y + 0.5f) / h;
      img.at(x, y, 2) = 0.25f;
    }
  return img;
}

// A strongly non-uniform test map: a smooth gradient, a bright spot, a black band.
Image test_map(int w = 32, int h = 16) {
  Image img(w, h, {"R", "G", "B"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float g = 0.1f + 0.9f * float(x) / w;
      float r = g, gg = 0.5f * g, b = 0.2f;
      if (x >= 5 && x <= 7 && y >= 3 && y <= 5) r = gg = b = 30.0f;  // the sun-ish spot
      if (y == 12) r = gg = b = 0.0f;                                 // a black row
      img.at(x, y, 0) = r;
      img.at(x, y, 1) = gg;
      img.at(x, y, 2) = b;
    }
  return img;
}

// ---- sphere binning for chi-square tests: equal-area bins in (z, phi).
struct SphereBins {
  int nz, nphi;
  int index(Vec3 d) const {
    d = normalize(d);
    int iz = std::clamp(int((d.z + 1.0f) * 0.5f * nz), 0, nz - 1);
    double phi = std::atan2(double(d.y), double(d.x)) + kPiD;
    int ip = std::clamp(int(phi / (2 * kPiD) * nphi), 0, nphi - 1);
    return iz * nphi + ip;
  }
  int count() const { return nz * nphi; }
  // Probability of each bin under a solid-angle density (midpoint rule, sub x sub).
  std::vector<double> probabilities(const std::function<double(Vec3)>& pdf, int sub) const {
    std::vector<double> p(size_t(count()), 0.0);
    const double dz = 2.0 / nz, dphi = 2 * kPiD / nphi;
    for (int iz = 0; iz < nz; ++iz)
      for (int ip = 0; ip < nphi; ++ip) {
        double acc = 0.0;
        for (int a = 0; a < sub; ++a)
          for (int b = 0; b < sub; ++b) {
            double z = -1.0 + dz * (iz + (a + 0.5) / sub);
            double phi = -kPiD + dphi * (ip + (b + 0.5) / sub);
            double r = std::sqrt(std::max(0.0, 1.0 - z * z));
            acc += pdf(Vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)));
          }
        p[size_t(iz) * nphi + ip] = acc * dz * dphi / (sub * sub);
      }
    return p;
  }
};

// Exact bin probabilities under an Environment's density: it is piecewise constant
// in (u, t = 1 - v) with value pdf_uv per texel, and a (z, phi) bin is a (u, t)
// rectangle (u = 0.5 - (phi + rotation) / 2 pi, t = acos(z) / pi).
std::vector<double> env_bin_probabilities(const Environment& env, const SphereBins& bins) {
  const int W = env.width(), H = env.height();
  std::vector<double> pdf_uv(size_t(W) * H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      float u = (x + 0.5f) / W, t = (y + 0.5f) / H;
      pdf_uv[size_t(y) * W + x] = env.pdf(env.uv_to_direction(u, 1.0f - t)) * 2 * kPiD * kPiD * std::sin(kPiD * t);
    }
  auto overlap = [](double a0, double a1, double b0, double b1) { return std::max(0.0, std::min(a1, b1) - std::max(a0, b0)); };
  std::vector<double> prob(size_t(bins.count()), 0.0);
  const double dz = 2.0 / bins.nz, dphi = 2 * kPiD / bins.nphi;
  for (int iz = 0; iz < bins.nz; ++iz) {
    double z0 = -1.0 + iz * dz, z1 = z0 + dz;
    double ta = std::acos(std::min(1.0, z1)) / kPiD, tb = std::acos(std::max(-1.0, z0)) / kPiD;
    for (int ip = 0; ip < bins.nphi; ++ip) {
      double phi1 = -kPiD + (ip + 1) * dphi;
      double ua = 0.5 - (phi1 + env.rotation_z()) / (2 * kPiD);
      ua -= std::floor(ua);
      double ub = ua + dphi / (2 * kPiD);
      double acc = 0.0;
      for (int y = 0; y < H; ++y) {
        double ot = overlap(ta, tb, double(y) / H, double(y + 1) / H);
        if (ot <= 0) continue;
        for (int x = 0; x < W; ++x) {
          double ou = overlap(ua, ub, double(x) / W, double(x + 1) / W) +
                      overlap(ua, ub, double(x) / W + 1.0, double(x + 1) / W + 1.0);
          acc += pdf_uv[size_t(y) * W + x] * ot * ou;
        }
      }
      prob[size_t(iz) * bins.nphi + ip] = acc;
    }
  }
  return prob;
}

// Integral over the sphere of a solid-angle function, on a fine (theta, phi) grid.
double integrate_sphere(const std::function<double(Vec3)>& f, int ntheta, int nphi) {
  double acc = 0.0;
  const double dt = kPiD / ntheta, dp = 2 * kPiD / nphi;
  for (int i = 0; i < ntheta; ++i) {
    double theta = (i + 0.5) * dt, st = std::sin(theta);
    for (int j = 0; j < nphi; ++j) {
      double phi = (j + 0.5) * dp;
      Vec3 d(float(st * std::cos(phi)), float(st * std::sin(phi)), float(std::cos(theta)));
      acc += f(d) * st;
    }
  }
  return acc * dt * dp;
}

}  // namespace

// ------------------------------------------------------------------ distributions

TEST(Environment, OrientationMatchesBlender) {
  Environment env(coded_map());
  // +x is u = 0.5, +y u = 0.25, -y u = 0.75, +z v = 1, -z v = 0.
  EnvUV uv = env.direction_to_uv(Vec3(1, 0, 0));
  EXPECT_NEAR(uv.u, 0.5f, 1e-6);
  EXPECT_NEAR(uv.v, 0.5f, 1e-6);
  EXPECT_NEAR(env.direction_to_uv(Vec3(0, 1, 0)).u, 0.25f, 1e-6);
  EXPECT_NEAR(env.direction_to_uv(Vec3(0, -1, 0)).u, 0.75f, 1e-6);
  EXPECT_NEAR(env.direction_to_uv(Vec3(0, 0, 1)).v, 1.0f, 1e-6);
  EXPECT_NEAR(env.direction_to_uv(Vec3(0, 0, -1)).v, 0.0f, 1e-6);
  // +z looks up the top row of the file (row 0), -z the bottom row.
  int x, y;
  env.texel_coords(Vec3(0.01f, 0.0f, 1.0f), &x, &y);
  EXPECT_EQ(y, 0);
  env.texel_coords(Vec3(0.01f, 0.0f, -1.0f), &x, &y);
  EXPECT_EQ(y, 7);
  // Just below +x, slightly toward -y: u a bit above 0.5 -> column 8 of 16.
  env.texel_coords(Vec3(1.0f, -0.01f, 0.0f), &x, &y);
  EXPECT_EQ(x, 8);
  EXPECT_EQ(y, 4);
  env.texel_coords(Vec3(1.0f, 0.01f, 0.01f), &x, &y);
  EXPECT_EQ(x, 7);
  EXPECT_EQ(y, 3);
  EXPECT_EQ(env.texel_index(Vec3(1.0f, 0.01f, 0.01f)), 3 * 16 + 7);
  // uv -> direction -> uv round trip.
  for (float u : {0.03f, 0.4f, 0.5f, 0.77f, 0.99f})
    for (float v : {0.02f, 0.3f, 0.5f, 0.9f}) {
      EnvUV back = env.direction_to_uv(env.uv_to_direction(u, v));
      EXPECT_NEAR(back.u, u, 1e-5);
      EXPECT_NEAR(back.v, v, 1e-5);
    }
}

// Colours Cycles 3.4 rendered (tests/blender/light_units_reference.py) for a camera
// looking along `d` at the texel-coded 16x8 map through a Mapping node (Z rotation)
// and a Background of `strength`, with Closest interpolation. Our lookup must
// return the same texel.
TEST(Environment, LookupMatchesCyclesRenders) {
  struct Case {
    Vec3 d;
    float rotation, strength;
    Vec3 rgb;
  };
  const Case cases[] = {
      {{0.988910941f, 0.138982369f, 0.052335956f}, 0.0f, 1.0f, {0.468750f, 0.437500f, 0.250000f}},
      {{-0.138982369f, 0.988910941f, 0.052335956f}, 0.0f, 1.0f, {0.218750f, 0.437500f, 0.250000f}},
      {{0.138982369f, -0.988910941f, 0.052335956f}, 0.0f, 1.0f, {0.718750f, 0.437500f, 0.250000f}},
      {{-0.988910941f, 0.138982369f, 0.052335956f}, 0.0f, 1.0f, {0.031250f, 0.437500f, 0.250000f}},
      {{0.526540785f, 0.368687826f, 0.766044443f}, 0.0f, 1.0f, {0.406250f, 0.187500f, 0.250000f}},
      {{-0.492403877f, -0.586824089f, -0.642787610f}, 0.0f, 1.0f, {0.843750f, 0.687500f, 0.250000f}},
      {{0.086824089f, 0.150383733f, 0.984807753f}, 0.0f, 1.0f, {0.343750f, 0.062500f, 0.250000f}},
      {{0.243210347f, -0.088521327f, -0.965925826f}, 0.0f, 1.0f, {0.531250f, 0.937500f, 0.250000f}},
      {{0.988910941f, 0.138982369f, 0.052335956f}, 1.0f, 2.0f, {0.687500f, 0.875000f, 0.500000f}},
      {{-0.138982369f, 0.988910941f, 0.052335956f}, 1.0f, 2.0f, {0.187500f, 0.875000f, 0.500000f}},
      {{0.138982369f, -0.988910941f, 0.052335956f}, 1.0f, 2.0f, {1.187500f, 0.875000f, 0.500000f}},
      {{-0.988910941f, 0.138982369f, 0.052335956f}, 1.0f, 2.0f, {1.687500f, 0.875000f, 0.500000f}},
      {{0.526540785f, 0.368687826f, 0.766044443f}, 1.0f, 2.0f, {0.437500f, 0.375000f, 0.500000f}},
      {{-0.492403877f, -0.586824089f, -0.642787610f}, 1.0f, 2.0f, {1.437500f, 1.375000f, 0.500000f}},
      {{0.086824089f, 0.150383733f, 0.984807753f}, 1.0f, 2.0f, {0.312500f, 0.125000f, 0.500000f}},
      {{0.243210347f, -0.088521327f, -0.965925826f}, 1.0f, 2.0f, {0.812500f, 1.875000f, 0.500000f}},
      {{0.988910941f, 0.138982369f, 0.052335956f}, -1.3f, 0.5f, {0.328125f, 0.218750f, 0.125000f}},
      {{-0.138982369f, 0.988910941f, 0.052335956f}, -1.3f, 0.5f, {0.203125f, 0.218750f, 0.125000f}},
      {{0.138982369f, -0.988910941f, 0.052335956f}, -1.3f, 0.5f, {0.453125f, 0.218750f, 0.125000f}},
      {{-0.988910941f, 0.138982369f, 0.052335956f}, -1.3f, 0.5f, {0.109375f, 0.218750f, 0.125000f}},
      {{0.526540785f, 0.368687826f, 0.766044443f}, -1.3f, 0.5f, {0.296875f, 0.093750f, 0.125000f}},
      {{-0.492403877f, -0.586824089f, -0.642787610f}, -1.3f, 0.5f, {0.046875f, 0.343750f, 0.125000f}},
      {{0.086824089f, 0.150383733f, 0.984807753f}, -1.3f, 0.5f, {0.265625f, 0.031250f, 0.125000f}},
      {{0.243210347f, -0.088521327f, -0.965925826f}, -1.3f, 0.5f, {0.390625f, 0.468750f, 0.125000f}},
  };
  Image img = coded_map();
  for (const Case& c : cases) {
    Environment env(img, c.strength, c.rotation);
    Vec3 L = env.eval(c.d);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(L[k], c.rgb[k], 1e-6) << "rotation " << c.rotation;
  }
}

TEST(Environment, RotationIsMappingNodeZRotation) {
  Environment env(coded_map());
  const float rot = 0.9f;
  Environment rotated(coded_map(), 1.0f, rot);
  // The texture is looked up at Rz(rot) d: what the unrotated map shows at d0,
  // the rotated one shows at Rz(-rot) d0.
  for (double az : {-2.5, -1.0, 0.1, 1.3, 2.9})
    for (double el : {-1.1, -0.2, 0.4, 1.2}) {
      Vec3 d0 = dir_from_angles(az, el);
      Vec3 d1 = rotate_z(d0, -rot);
      EXPECT_EQ(env.texel_index(d0), rotated.texel_index(d1));
      EnvUV a = env.direction_to_uv(d0), b = rotated.direction_to_uv(d1);
      EXPECT_NEAR(a.u, b.u, 1e-5);
      EXPECT_NEAR(a.v, b.v, 1e-5);
      EnvUV r = rotated.direction_to_uv(rotated.uv_to_direction(a.u, a.v));
      EXPECT_NEAR(r.u, a.u, 1e-5);
    }
  // Positive rotation moves the +x feature toward -y.
  EnvUV uv = rotated.direction_to_uv(rotate_z(Vec3(1, 0, 0), -rot));
  EXPECT_NEAR(uv.u, 0.5f, 1e-6);
  EXPECT_LT(rotate_z(Vec3(1, 0, 0), -rot).y, 0.0f);
}

TEST(Environment, StrengthScalesRadianceNotPdf) {
  Environment a(test_map()), b(test_map(), 3.0f);
  Vec3 d = normalize(Vec3(0.3f, -0.5f, 0.4f));
  EXPECT_NEAR(b.eval(d).x, 3.0f * a.eval(d).x, 1e-6);
  EXPECT_FLOAT_EQ(a.pdf(d), b.pdf(d));
}

// ------------------------------------------------------------------ sampling

TEST(Environment, PdfIntegratesToOne) {
  for (float rot : {0.0f, 0.7f}) {
    Environment env(test_map(), 1.0f, rot);
    double integral = integrate_sphere([&](Vec3 d) { return env.pdf(d); }, 800, 1600);
    EXPECT_NEAR(integral, 1.0, 2e-3) << rot;
  }
  Environment uniform = Environment::constant(Vec3(1.0f), 4, 2);
  EXPECT_NEAR(integrate_sphere([&](Vec3 d) { return uniform.pdf(d); }, 400, 800), 1.0, 2e-3);
}

TEST(Environment, SamplingChiSquareAgainstPdf) {
  Environment env(test_map(), 2.0f, 0.4f);
  SphereBins bins{20, 40};
  std::vector<double> prob = env_bin_probabilities(env, bins);
  double total = 0;
  for (double p : prob) total += p;
  EXPECT_NEAR(total, 1.0, 1e-6);
  // The exact bin probabilities agree with quadrature of pdf() (checks pdf() itself).
  std::vector<double> quad = bins.probabilities([&](Vec3 d) { return env.pdf(d); }, 24);
  double l1 = 0;
  for (int i = 0; i < bins.count(); ++i) l1 += std::fabs(quad[i] - prob[i]);
  EXPECT_LT(l1, 0.01);
  const int n = 400000;
  std::vector<int> counts(bins.count(), 0);
  Rng rng(42);
  int mismatched = 0;
  for (int i = 0; i < n; ++i) {
    EnvSample s = env.sample(rng.next(), rng.next());
    ASSERT_TRUE(s.valid());
    counts[bins.index(s.wi)]++;
    // The sample's pdf and Li are those of its direction (up to texel-edge rounding).
    float p = env.pdf(s.wi);
    if (std::fabs(p - s.pdf) > 1e-3f * s.pdf || std::fabs(env.eval(s.wi).x - s.Li.x) > 1e-5f) ++mismatched;
  }
  EXPECT_LT(mismatched, n / 10000);
  double chi2 = 0;
  double z = test::chi2_z(prob, counts, n, &chi2);
  EXPECT_LT(std::fabs(z), 4.0) << "chi2 " << chi2;
}

TEST(Environment, ImportanceSampledIrradianceMatchesQuadrature) {
  Environment env(test_map(), 1.0f, 0.3f);
  const Vec3 n = normalize(Vec3(0.2f, 0.3f, 0.9f));
  double ref = integrate_sphere([&](Vec3 d) { return double(env.eval(d).x) * std::max(0.0f, dot(d, n)); }, 800, 1600);
  Rng rng(3);
  const int N = 400000;
  double acc = 0.0;
  for (int i = 0; i < N; ++i) {
    EnvSample s = env.sample(rng.next(), rng.next());
    if (s.valid()) acc += s.Li.x * std::max(0.0f, dot(s.wi, n)) / s.pdf;
  }
  EXPECT_NEAR(acc / N, ref, 0.01 * ref);
}

TEST(Environment, SamplesFollowLuminanceAndAvoidBlackTexels) {
  // Only texel (3, 0) (touching the pole row) and (10, 5) are lit.
  Image img(16, 8, {"R", "G", "B"});
  for (int c = 0; c < 3; ++c) {
    img.at(3, 0, c) = 1.0f;
    img.at(10, 5, c) = 1.0f;
  }
  Environment env(img);
  Rng rng(5);
  for (int i = 0; i < 20000; ++i) {
    EnvSample s = env.sample(rng.next(), rng.next());
    ASSERT_TRUE(s.valid());
    ASSERT_TRUE(s.texel == 3 || s.texel == 5 * 16 + 10);
    ASSERT_GT(s.Li.x, 0.0f);
  }
  // Exactly at the pole the density is undefined: 0, never inf/nan.
  EXPECT_EQ(env.pdf(Vec3(0, 0, 1)), 0.0f);
  EXPECT_TRUE(std::isfinite(env.pdf(Vec3(1e-4f, 0, 1))));
  // Black texels have zero density.
  EXPECT_EQ(env.pdf(env.uv_to_direction(0.9f, 0.5f)), 0.0f);
  // An all-black map still samples (uniformly in (u, v)) with a consistent pdf.
  Environment black(Image(8, 4, {"R", "G", "B"}));
  EnvSample s = black.sample(0.3f, 0.6f);
  EXPECT_TRUE(s.valid());
  EXPECT_NEAR(black.pdf(s.wi), s.pdf, 1e-4f * s.pdf);
  EXPECT_EQ(s.Li.x, 0.0f);
}

TEST(Environment, RebuildSamplingAfterTexelEdits) {
  Environment env = Environment::constant(Vec3(1.0f), 16, 8);
  Vec3 d = env.uv_to_direction((4 + 0.5f) / 16, 1.0f - (2 + 0.5f) / 8);
  float before = env.pdf(d);
  env.set_texel(4, 2, Vec3(100.0f));
  EXPECT_FLOAT_EQ(env.pdf(d), before);  // stale until rebuilt, but consistent
  EXPECT_NEAR(env.eval(d).x, 100.0f, 1e-6);
  env.rebuild_sampling();
  EXPECT_GT(env.pdf(d), 10.0f * before);
  EXPECT_EQ(env.texels().size(), size_t(16 * 8 * 3));
  EXPECT_EQ(env.texels()[(2 * 16 + 4) * 3], 100.0f);
}

TEST(Environment, LoadsExrAndNamesTheFileOnError) {
  namespace fs = std::filesystem;
  fs::create_directories(PTIR_TEST_TMP);
  std::string path = std::string(PTIR_TEST_TMP) + "/env_coded.exr";
  write_image(path, coded_map());
  Environment env = Environment::load(path, 1.5f);
  EXPECT_EQ(env.width(), 16);
  EXPECT_EQ(env.height(), 8);
  Vec3 top = env.texel(5, 0);
  EXPECT_NEAR(top.x, 5.5f / 16, 1e-6);
  EXPECT_NEAR(top.y, 0.5f / 8, 1e-6);
  EXPECT_NEAR(env.eval(Vec3(0.01f, 0.0f, 1.0f)).y, 1.5f * 0.5f / 8, 1e-6);
  std::string missing = std::string(PTIR_TEST_TMP) + "/no_such_env.exr";
  try {
    Environment::load(missing);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_env.exr"), std::string::npos) << e.what();
  }
  Image two(4, 2, {"R", "G"});
  try {
    Environment bad(two, 1.0f, 0.0f, "two_channels.exr");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("two_channels.exr"), std::string::npos) << e.what();
  }
}

// ------------------------------------------------------------------ spherical Gaussians

TEST(SgEnvironment, DefaultsFollowPtir) {
  SgEnvironment sg;
  ASSERT_EQ(sg.size(), 24);
  EXPECT_FLOAT_EQ(sg.gamma(), 0.3f);
  for (int i = 0; i < sg.size(); ++i) {
    EXPECT_FLOAT_EQ(sg.sharpness()[i], i % 2 == 0 ? 1.0f : 20.0f);
    EXPECT_FLOAT_EQ(sg.raw()[i].x, -3.5f);
    EXPECT_NEAR(length(sg.axes()[i]), 1.0f, 1e-6);
  }
  // c = exp(softplus(-3.5) / 0.3) - 1.
  double c = std::exp(std::log1p(std::exp(-3.5)) / 0.3) - 1.0;
  EXPECT_NEAR(sg.amplitude(0).y, c, 1e-6);
  // Fibonacci axes cover the sphere: their mean is ~0.
  Vec3 mean(0.0f);
  for (Vec3 a : sg.axes()) mean += a / float(sg.size());
  EXPECT_LT(length(mean), 0.05f);
}

TEST(SgEnvironment, LobeIntegralMatchesQuadrature) {
  for (float lambda : {0.01f, 1.0f, 20.0f, 200.0f}) {
    SgEnvironment sg(1);
    sg.sharpness()[0] = lambda;
    sg.axes()[0] = normalize(Vec3(0.3f, -0.2f, 0.8f));
    sg.raw()[0] = Vec3(2.0f);
    sg.update();
    const Vec3 axis = sg.axes()[0];
    // 1D quadrature in mu (exact reduction of the sphere integral) ...
    const int n = 200000;
    double acc = 0.0;
    for (int i = 0; i < n; ++i) {
      double mu = -1.0 + 2.0 * (i + 0.5) / n;
      acc += std::exp(lambda * (mu - 1.0));
    }
    acc *= 2.0 * kPiD * 2.0 / n;
    EXPECT_NEAR(SgEnvironment::lobe_integral(lambda), acc, 1e-6 * acc) << lambda;
    // ... and the full sphere integral of the lobe's L.
    if (lambda <= 20.0f) {
      double num = integrate_sphere([&](Vec3 d) { return sg.eval(d).x; }, 1000, 2000);
      EXPECT_NEAR(num, sg.amplitude(0).x * SgEnvironment::lobe_integral(lambda), 2e-3 * num) << lambda;
      double pdf_int = integrate_sphere([&](Vec3 d) { return sg.lobe_pdf(0, d); }, 1000, 2000);
      EXPECT_NEAR(pdf_int, 1.0, 2e-3) << lambda;
    }
    (void)axis;
  }
}

TEST(SgEnvironment, LobeSamplingChiSquare) {
  SgEnvironment sg(6);
  for (int lobe : {0, 1, 3}) {
    sg.sharpness()[lobe] = lobe == 0 ? 1.0f : (lobe == 1 ? 20.0f : 5.0f);
  }
  sg.update();
  for (int lobe : {0, 1, 3}) {
    SphereBins bins{24, 48};
    std::vector<double> prob = bins.probabilities([&](Vec3 d) { return sg.lobe_pdf(lobe, d); }, 10);
    const int n = 300000;
    std::vector<int> counts(bins.count(), 0);
    Rng rng(100 + lobe);
    for (int i = 0; i < n; ++i) counts[bins.index(sg.sample_lobe(lobe, rng.next(), rng.next()))]++;
    double chi2 = 0;
    EXPECT_LT(std::fabs(test::chi2_z(prob, counts, n, &chi2)), 4.0) << "lobe " << lobe << " chi2 " << chi2;
  }
  // Extreme uniforms stay finite and on the sphere.
  for (float u : {0.0f, 1e-7f, 0.5f, 0.99999994f, 1.0f}) {
    Vec3 d = sg.sample_lobe(1, u, 0.3f);
    EXPECT_NEAR(length(d), 1.0f, 1e-5) << u;
    EXPECT_TRUE(std::isfinite(sg.lobe_pdf(1, d)));
  }
}

TEST(SgEnvironment, MixturePdfIntegratesToOneAndMatchesSampling) {
  SgEnvironment sg;
  Rng init(9);
  for (int i = 0; i < sg.size(); ++i)
    sg.raw()[i] = Vec3(-4.0f + 6.0f * init.next(), -4.0f + 6.0f * init.next(), -4.0f + 6.0f * init.next());
  sg.raw()[5] = Vec3(-30.0f);  // a practically black lobe
  sg.update();
  double total_prob = 0;
  for (int i = 0; i < sg.size(); ++i) total_prob += sg.lobe_probability(i);
  EXPECT_NEAR(total_prob, 1.0, 1e-5);
  EXPECT_NEAR(integrate_sphere([&](Vec3 d) { return sg.pdf(d); }, 1000, 2000), 1.0, 2e-3);

  SphereBins bins{24, 48};
  std::vector<double> prob = bins.probabilities([&](Vec3 d) { return sg.pdf(d); }, 10);
  const int n = 400000;
  std::vector<int> counts(bins.count(), 0);
  Rng rng(11);
  for (int i = 0; i < n; ++i) {
    SgSample s = sg.sample(rng.next(), rng.next(), rng.next());
    ASSERT_TRUE(s.valid());
    ASSERT_NEAR(s.pdf, sg.pdf(s.wi), 1e-4f * s.pdf);
    ASSERT_NEAR(s.Li.y, sg.eval(s.wi).y, 1e-5f * (1.0f + s.Li.y));
    counts[bins.index(s.wi)]++;
  }
  double chi2 = 0;
  EXPECT_LT(std::fabs(test::chi2_z(prob, counts, n, &chi2)), 4.0) << "chi2 " << chi2;

  // Lobe choice is proportional to energy = luminance(c) * integral.
  double e_sum = 0;
  std::vector<double> e(sg.size());
  for (int i = 0; i < sg.size(); ++i) {
    e[i] = luminance(sg.amplitude(i)) * SgEnvironment::lobe_integral(sg.sharpness()[i]);
    e_sum += e[i];
  }
  for (int i = 0; i < sg.size(); ++i) EXPECT_NEAR(sg.lobe_probability(i), e[i] / e_sum, 1e-5);

  // MC estimate of the total power agrees with the analytic sum of lobe integrals.
  double analytic = 0;
  for (int i = 0; i < sg.size(); ++i) analytic += sg.amplitude(i).x * SgEnvironment::lobe_integral(sg.sharpness()[i]);
  Rng rng2(12);
  double mc = 0;
  const int m = 200000;
  for (int i = 0; i < m; ++i) {
    SgSample s = sg.sample(rng2.next(), rng2.next(), rng2.next());
    mc += s.Li.x / s.pdf;
  }
  EXPECT_NEAR(mc / m, analytic, 0.01 * analytic);
}

TEST(SgEnvironment, DerivativeMatchesFiniteDifferences) {
  SgEnvironment sg(5);
  Rng init(21);
  for (int i = 0; i < sg.size(); ++i) sg.raw()[i] = Vec3(-3.0f + 4.0f * init.next(), -1.0f, 0.5f * init.next());
  sg.update();
  const Vec3 v = normalize(Vec3(0.4f, -0.3f, 0.5f));
  std::vector<Vec3> grad;
  sg.d_eval_d_raw(v, grad);
  ASSERT_EQ(int(grad.size()), sg.size());
  const float h = 1e-2f;
  for (int i = 0; i < sg.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      SgEnvironment p = sg, m = sg;
      p.raw()[i][c] += h;
      m.raw()[i][c] -= h;
      p.update();
      m.update();
      double fd = (double(p.eval(v)[c]) - double(m.eval(v)[c])) / (2.0 * h);
      EXPECT_NEAR(grad[i][c], fd, 1e-3 * std::fabs(fd) + 1e-6) << i << " " << c;
      // Other channels do not depend on this channel's raw value.
      int o = (c + 1) % 3;
      EXPECT_NEAR(p.eval(v)[o], sg.eval(v)[o], 1e-6);
    }
  // Analytic derivative of c(x) itself.
  for (float x : {-8.0f, -3.5f, 0.0f, 2.0f}) {
    double fd = (SgEnvironment::amplitude_from_raw(Vec3(x + 1e-3f), 0.3f).x -
                 SgEnvironment::amplitude_from_raw(Vec3(x - 1e-3f), 0.3f).x) / 2e-3;
    EXPECT_NEAR(SgEnvironment::d_amplitude_d_raw(Vec3(x), 0.3f).x, fd, 2e-3 * std::fabs(fd) + 1e-6) << x;
  }
}

TEST(SgEnvironment, LatLongRasterUsesEnvironmentOrientation) {
  SgEnvironment sg(3);
  sg.axes()[0] = Vec3(1, 0, 0);
  sg.axes()[1] = Vec3(0, 0, 1);
  sg.axes()[2] = Vec3(0, -1, 0);
  sg.raw() = {Vec3(2.0f, -9.0f, -9.0f), Vec3(-9.0f, 2.0f, -9.0f), Vec3(-9.0f, -9.0f, 2.0f)};
  sg.sharpness() = {50.0f, 50.0f, 50.0f};
  sg.update();
  Image img = sg.to_latlong(128, 64);
  Environment env(img);
  // Red lobe at +x, green at +z (top row), blue at -y (u = 0.75).
  auto argmax = [&](int channel) {
    int best = 0;
    for (int i = 1; i < 128 * 64; ++i)
      if (img.pixels[size_t(i) * 3 + channel] > img.pixels[size_t(best) * 3 + channel]) best = i;
    return best;
  };
  EXPECT_EQ(argmax(0), env.texel_index(Vec3(1.0f, 0.001f, 0.001f)));
  EXPECT_LT(argmax(1) / 128, 1);  // top row
  EXPECT_EQ(argmax(2), env.texel_index(Vec3(0.001f, -1.0f, 0.001f)));
  // Texel centres hold eval() of their centre direction.
  for (int y : {3, 20, 40})
    for (int x : {0, 64, 100}) {
      Vec3 d = env.uv_to_direction((x + 0.5f) / 128, 1.0f - (y + 0.5f) / 64);
      EXPECT_NEAR(img.at(x, y, 0), sg.eval(d).x, 1e-4f * (1.0f + sg.eval(d).x));
    }
}
