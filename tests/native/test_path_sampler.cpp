// Stratified path numbers (math/path_sampler.h): the first 2^k samples of a
// pixel are stratified (one per 1D stratum in every coordinate, a (0, k, 2)-net
// in coordinates 0 and 1), every number is uniform across pixels, the index
// shuffle maps aligned blocks onto aligned blocks, groups are decorrelated, and the same keys
// give the same numbers (replay).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

#include "chi2_test.h"
#include "ptir/math/path_sampler.h"

using namespace ptir;

TEST(PathSampler, UnscrambledSobolIsAZeroNet) {
  // Coordinates 0 and 1 of the first 2^k points: one point in every elementary interval.
  for (int k = 1; k <= 8; ++k) {
    const uint32_t n = 1u << k;
    for (int a = 0; a <= k; ++a) {
      std::set<std::pair<uint32_t, uint32_t>> cells;
      for (uint32_t i = 0; i < n; ++i)
        cells.insert({sobol_detail::sobol(i, 0) >> (32 - a) >> 0, a == k ? 0u : sobol_detail::sobol(i, 1) >> (32 - (k - a))});
      EXPECT_EQ(cells.size(), n) << "k=" << k << " a=" << a;
    }
  }
}

TEST(PathSampler, ByteTablesGiveTheSobolSum) {
  // The table lookup against the definition: the XOR of the direction numbers of
  // the index's set bits, over full 32-bit (scrambled) indices and small ones.
  uint64_t state = 12345;
  for (int n = 0; n < 20000; ++n) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    const uint32_t index = n < 300 ? uint32_t(n) : uint32_t(state >> 32);
    for (int d = 0; d < 4; ++d) {
      uint32_t x = 0;
      for (int k = 0; k < 32; ++k)
        if ((index >> k) & 1u) x ^= sobol_detail::kDirections.v[d][k];
      ASSERT_EQ(sobol_detail::sobol(index, d), x) << "index " << index << " dim " << d;
    }
  }
  // Dimension 0 is the van der Corput sequence: the index's bits reversed.
  EXPECT_EQ(sobol_detail::sobol(1u, 0), 0x80000000u);
  EXPECT_EQ(sobol_detail::sobol(0x12345678u, 0), sobol_detail::reverse_bits(0x12345678u));
}

TEST(PathSampler, PixelSamplesAreStratified) {
  for (uint64_t pixel : {0ull, 17ull, 123456ull})
    for (uint64_t bounce : {0ull, 3ull})
      for (uint64_t stream : {1ull, 3ull, 16ull}) {
        const int k = 6, n = 1 << k;
        std::vector<std::set<int>> strata(4);
        std::set<std::pair<int, int>> net[k + 1];
        for (int s = 0; s < n; ++s) {
          PathRng r(make_path_key(9, pixel, uint32_t(s)), bounce, stream);
          for (int i = 0; i < 4; ++i) {
            float u = r.at(uint64_t(i));
            ASSERT_TRUE(u >= 0.0f && u < 1.0f);
            strata[size_t(i)].insert(int(u * n));
          }
          for (int a = 0; a <= k; ++a) net[a].insert({int(r.at(0) * (1 << a)), int(r.at(1) * (1 << (k - a)))});
        }
        for (int i = 0; i < 4; ++i) EXPECT_EQ(strata[size_t(i)].size(), size_t(n)) << "coordinate " << i;
        for (int a = 0; a <= k; ++a) EXPECT_EQ(net[a].size(), size_t(n)) << "(0,1) elementary intervals, a=" << a;
      }
}

TEST(PathSampler, ShuffleMapsAlignedBlocksOntoThemselves) {
  for (uint32_t seed : {1u, 0xdeadbeefu, 77u}) {
    std::set<uint32_t> block;
    for (uint32_t i = 0; i < 32; ++i) block.insert(sobol_detail::nested_uniform_scramble(i, seed));
    // The image is one aligned block of 32 (whose Sobol' points are a net like the first block's).
    EXPECT_EQ(block.size(), 32u);
    EXPECT_EQ(*block.begin() % 32u, 0u);
    EXPECT_EQ(*block.rbegin() - *block.begin(), 31u);
  }
}

TEST(PathSampler, NumbersAreUniformAcrossPixelsAndGroupsIndependent) {
  // Sample 5 of 200000 pixels: every coordinate uniform (chi-square), and two groups uncorrelated.
  const int n = 200000, bins = 50;
  std::vector<std::vector<double>> obs(4, std::vector<double>(bins, 0.0));
  double sxy = 0, sx = 0, sy = 0, sxx = 0, syy = 0;
  for (int p = 0; p < n; ++p) {
    uint64_t key = make_path_key(3, uint64_t(p), 5);
    PathRng a(key, 1, 3), b(key, 1, 16);
    for (int i = 0; i < 4; ++i) obs[size_t(i)][size_t(a.at(uint64_t(i)) * bins)] += 1.0;
    double x = a.at(0), y = b.at(0);
    sx += x, sy += y, sxy += x * y, sxx += x * x, syy += y * y;
  }
  std::vector<double> exp(bins, double(n) / bins);
  for (int i = 0; i < 4; ++i) {
    auto r = ptir::test::chi2_test(obs[size_t(i)], exp);
    EXPECT_GT(r.p_value, 1e-3) << "coordinate " << i << ": " << r.summary();
  }
  double cov = sxy / n - (sx / n) * (sy / n);
  double corr = cov / std::sqrt((sxx / n - (sx / n) * (sx / n)) * (syy / n - (sy / n) * (sy / n)));
  EXPECT_LT(std::fabs(corr), 0.01);
}

TEST(PathSampler, SameKeysSameNumbers) {
  uint64_t key = make_path_key(11, 4242, 37);
  EXPECT_EQ(key & 0xFFFFFFu, 37u);
  PathRng a(key, 2, 3), b(key, 2, 3), c(key, 2, 4);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(a.at(uint64_t(i)), b.at(uint64_t(i)));
  EXPECT_NE(a.at(0), c.at(0));
  EXPECT_NE(make_path_key(11, 4242, 37), make_path_key(11, 4243, 37));
}
