// The coarse-to-fine environment (optim/env_pyramid.h): the upsampler and its
// adjoint agree (<up c, f> = <c, up^T f>), a constant coarse level lifts every
// texel by that constant, and u wraps around the seam.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "ptir/optim/env_pyramid.h"

using namespace ptir;

TEST(EnvPyramid, AdjointMatchesUpsampling) {
  const int cw = 8, ch = 4, W = 32, H = 16;
  LatlongUpsampler up(cw, ch, W, H);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> c(up.coarse_size()), f(size_t(W) * H * 3), upc(f.size(), 0.0f), dc(c.size());
  for (float& v : c) v = u(rng);
  for (float& v : f) v = u(rng);
  up.add_up(c.data(), upc.data());
  up.adjoint(f.data(), dc.data());
  double lhs = 0.0, rhs = 0.0;
  for (size_t i = 0; i < f.size(); ++i) lhs += double(upc[i]) * f[i];
  for (size_t i = 0; i < c.size(); ++i) rhs += double(c[i]) * dc[i];
  EXPECT_NEAR(lhs, rhs, 1e-4 * std::abs(lhs) + 1e-5);
}

TEST(EnvPyramid, ConstantCoarseLiftsEveryTexel) {
  LatlongUpsampler up(4, 2, 16, 8);
  std::vector<float> c(up.coarse_size(), 0.7f), f(16 * 8 * 3, 1.0f);
  up.add_up(c.data(), f.data());
  for (float v : f) EXPECT_NEAR(v, 1.7f, 1e-6f);
}

TEST(EnvPyramid, SeamWraps) {
  // One hot coarse texel in the last column also reaches the first fine columns (u wraps).
  LatlongUpsampler up(4, 2, 16, 8);
  std::vector<float> c(up.coarse_size(), 0.0f), f(16 * 8 * 3, 0.0f);
  c[(0 * 4 + 3) * 3] = 1.0f;  // row 0, column 3, red
  up.add_up(c.data(), f.data());
  EXPECT_GT(f[(0 * 16 + 0) * 3], 0.0f);   // fine column 0 blends coarse columns 3 and 0
  EXPECT_EQ(f[(0 * 16 + 6) * 3], 0.0f);   // fine column 6 lies between coarse 1 and 2
}
