// The environment's priors (optim/env_smoothness.h) against closed forms on the
// sphere (Dirichlet energy of z and x; variance of z^2) and finite differences.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "ptir/optim/env_smoothness.h"

using namespace ptir;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A log-radiance map f(direction) on a W x H lat-long grid (Blender's convention:
// theta from +z, the same in every channel but scaled per channel by 1, 2, 3).
template <class F>
std::vector<float> sample_map(int W, int H, F f) {
  std::vector<float> m(size_t(W) * H * 3);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double theta = (y + 0.5) * kPi / H, phi = (x + 0.5) * 2.0 * kPi / W;
      const double d[3] = {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
      for (int c = 0; c < 3; ++c) m[(size_t(y) * W + x) * 3 + c] = float((c + 1) * f(d));
    }
  return m;
}

// A prior's gradient (weight x dE/dr, accumulated by `prior`) against central
// differences at a random 16 x 8 map: pole rows, the seam column and interior texels.
template <class Prior>
void expect_gradient_matches_finite_differences(Prior prior, uint32_t seed, float weight, double abs_tol) {
  const int W = 16, H = 8;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  std::vector<float> r(size_t(W) * H * 3), g(r.size(), 0.0f);
  for (float& v : r) v = u(rng);
  prior(r.data(), W, H, g.data(), weight);
  for (size_t i : {size_t(0), size_t(5), size_t((0 * W + W - 1) * 3 + 1), size_t((3 * W + 7) * 3 + 2),
                   size_t(((H - 1) * W + 2) * 3), size_t(((H - 1) * W + 2) * 3 + 1)}) {
    std::vector<float> p = r, m = r;
    const float h = 1e-2f;
    p[i] += h;
    m[i] -= h;
    const double fd = weight * (prior(p.data(), W, H, nullptr, 1.0f) - prior(m.data(), W, H, nullptr, 1.0f)) / (2.0 * h);
    EXPECT_NEAR(g[i], fd, 1e-3 * std::abs(fd) + abs_tol) << i;
  }
}

}  // namespace

TEST(EnvSmoothness, MatchesTheSpheresDirichletEnergy) {
  // For f = a z and f = a x, integral |grad f|^2 dOmega = 8 pi a^2 / 3; over 4 pi and
  // summed over channels scaled 1, 2, 3: E = (2/3) a^2 (1 + 4 + 9).
  const double a = 0.8, expected = 2.0 / 3.0 * a * a * 14.0;
  for (int W : {64, 256}) {
    const int H = W / 2;
    auto z = sample_map(W, H, [&](const double* d) { return a * d[2]; });
    auto x = sample_map(W, H, [&](const double* d) { return a * d[0]; });
    const double tol = W == 64 ? 0.02 : 0.005;  // the discretisation error shrinks with the grid
    EXPECT_NEAR(latlong_log_dirichlet(z.data(), W, H), expected, tol * expected) << W;
    EXPECT_NEAR(latlong_log_dirichlet(x.data(), W, H), expected, tol * expected) << W;
  }
  // A constant map (any brightness or colour) has no energy.
  std::vector<float> c(size_t(32) * 16 * 3);
  for (size_t i = 0; i < c.size(); ++i) c[i] = float(i % 3) - 0.3f;
  EXPECT_NEAR(latlong_log_dirichlet(c.data(), 32, 16), 0.0, 1e-9);
}

TEST(EnvSmoothness, GradientMatchesFiniteDifferences) {
  expect_gradient_matches_finite_differences(latlong_log_dirichlet, 5, 0.7f, 1e-4);
}

TEST(EnvChroma, VarianceOfTheLogChromaticity) {
  // Grey light of any brightness distribution, and a global tint: no energy.
  const int W = 64, H = 32;
  auto tinted = sample_map(W, H, [](const double* d) { return 2.0 * d[2] * d[2]; });  // channels 1x, 2x, 3x: a tint that varies
  std::vector<float> grey(size_t(W) * H * 3), tint(grey.size());
  for (size_t t = 0; t < grey.size() / 3; ++t)
    for (int c = 0; c < 3; ++c) {
      grey[3 * t + c] = tinted[3 * t];              // the same log radiance in all channels
      tint[3 * t + c] = tinted[3 * t] + 0.4f * c;   // plus a constant per-channel offset
    }
  EXPECT_NEAR(latlong_log_chroma_variance(grey.data(), W, H), 0.0, 1e-9);
  EXPECT_NEAR(latlong_log_chroma_variance(tint.data(), W, H), 0.0, 1e-9);
  // Log chromaticity q = (c+1 - 2) f for f = 2 z^2: q_c = (c - 1) f, so C = sum_c (c-1)^2 Var(f) = 2 Var(f),
  // with Var(2 z^2) over the sphere = 4 (E[z^4] - E[z^2]^2) = 4 (1/5 - 1/9) = 16/45.
  EXPECT_NEAR(latlong_log_chroma_variance(tinted.data(), W, H), 2.0 * 16.0 / 45.0, 2e-3);
}

TEST(EnvChroma, GradientMatchesFiniteDifferences) {
  expect_gradient_matches_finite_differences(latlong_log_chroma_variance, 7, 1.3f, 1e-5);
}
