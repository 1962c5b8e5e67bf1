// The piecewise-constant distributions behind every importance-sampled light
// (lights/distribution.h): samples follow the pmf and skip zero bins, the guide
// table finds the binary search's bin, the all-zero fallback, and the 2D
// distribution's pdf against its samples.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "ptir/lights/distribution.h"
#include "ptir/math/rng.h"
#include "chi2_test.h"

using namespace ptir;

TEST(Distribution1D, SamplesMatchPmfAndSkipZeroBins) {
  std::vector<float> f = {0.0f, 1.0f, 0.0f, 3.0f, 0.0f};
  Distribution1D d(f);
  EXPECT_NEAR(d.integral(), 4.0 / 5.0, 1e-7);
  EXPECT_FLOAT_EQ(d.pmf(1), 0.25f);
  EXPECT_FLOAT_EQ(d.pmf(3), 0.75f);
  EXPECT_FLOAT_EQ(d.pdf(0.7f), 0.75f * 5);
  // CDF steps: u exactly on a step, 0, and just below 1 never land in empty bins.
  for (float u : {0.0f, 0.25f, 0.2500001f, 0.5f, 0.99999994f, 1.0f}) {
    int i = -1;
    float pdf = 0;
    float x = d.sample_continuous(u, &pdf, &i);
    EXPECT_TRUE(i == 1 || i == 3) << u;
    EXPECT_GT(pdf, 0.0f);
    EXPECT_GE(x, i / 5.0f);
    EXPECT_LT(x, (i + 1) / 5.0f);
    EXPECT_FLOAT_EQ(pdf, d.pdf(x));
  }
  // Continuous samples are uniform inside the bin: u in [0.25, 1) -> x in [0.6, 0.8).
  EXPECT_NEAR(d.sample_continuous(0.625f), 0.7f, 1e-6);
}

TEST(Distribution1D, BinSearchMatchesBinarySearchOfTheCdf) {
  // The drawn bin against std::upper_bound over the CDF (rebuilt here as the
  // constructor builds it): peaked, sparse and odd-sized functions, with u on and
  // next to every CDF step and at random.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> uni(0.0f, 1.0f);
  for (int n : {1, 2, 3, 5, 64, 100, 128, 257}) {
    for (int shape = 0; shape < 3; ++shape) {
      std::vector<float> f(static_cast<size_t>(n), 0.0f);
      for (int i = 0; i < n; ++i) {
        const float r = uni(rng);
        f[i] = shape == 0 ? r : shape == 1 ? (r < 0.7f ? 0.0f : r) : (i == n / 3 ? 1000.0f : 1e-3f * r);
      }
      std::vector<double> cdf(size_t(n) + 1, 0.0);
      for (int i = 0; i < n; ++i) cdf[i + 1] = cdf[i] + f[i];
      const double sum = cdf[n];
      if (!(sum > 0.0)) continue;
      for (int i = 1; i <= n; ++i) cdf[i] /= sum;
      cdf[n] = 1.0;
      std::vector<float> us;
      for (int i = 0; i <= n; ++i) {
        const float c = float(cdf[i]);
        us.insert(us.end(), {c, std::nextafter(c, 0.0f), std::nextafter(c, 1.0f)});
      }
      for (int k = 0; k < 2000; ++k) us.push_back(uni(rng));
      Distribution1D d(f);
      for (float u : us) {
        const float uc = std::clamp(u, 0.0f, 0.99999994f);
        const int expected =
            std::clamp(int(std::upper_bound(cdf.begin(), cdf.begin() + n, double(uc)) - cdf.begin()) - 1, 0, n - 1);
        ASSERT_EQ(d.sample_discrete(u), expected) << "n " << n << " shape " << shape << " u " << u;
      }
    }
  }
}

TEST(Distribution1D, AllZeroFallsBackToUniform) {
  std::vector<float> f = {0.0f, 0.0f, -1.0f, std::nanf("")};
  Distribution1D d(f);
  EXPECT_EQ(d.integral(), 0.0);
  EXPECT_FLOAT_EQ(d.pdf(0.3f), 1.0f);
  EXPECT_FLOAT_EQ(d.pmf(2), 0.25f);
  EXPECT_NEAR(d.sample_continuous(0.3f), 0.3f, 1e-6);
}

TEST(Distribution2D, PdfIntegratesToOneAndMatchesSamples) {
  const int nx = 7, ny = 5;
  std::vector<float> f(nx * ny);
  for (int i = 0; i < nx * ny; ++i) f[i] = float((i * 37) % 11);  // includes zeros
  Distribution2D d(f.data(), nx, ny);
  double sum = 0.0;
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x) sum += d.pdf_cell(x, y) / double(nx * ny);
  EXPECT_NEAR(sum, 1.0, 1e-6);
  // Cell frequencies follow f.
  Rng rng(7);
  const int n = 200000;
  std::vector<int> counts(nx * ny, 0);
  for (int i = 0; i < n; ++i) {
    Sample2D s = d.sample(rng.next(), rng.next());
    ASSERT_GT(f[s.iy * nx + s.ix], 0.0f);
    ASSERT_FLOAT_EQ(s.pdf, d.pdf(s.x, s.y));
    counts[s.iy * nx + s.ix]++;
  }
  std::vector<double> prob(nx * ny);
  double total = 0;
  for (float v : f) total += v;
  for (int i = 0; i < nx * ny; ++i) prob[i] = f[i] / total;
  EXPECT_LT(std::fabs(test::chi2_z(prob, counts, n)), 4.0);
}

// ------------------------------------------------------------------ lat-long orientation
