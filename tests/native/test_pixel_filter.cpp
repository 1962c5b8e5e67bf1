// Pixel filter importance sampling (math/pixel_filter.h): the warped offsets
// follow the analytic filter profiles with Cycles' width conventions (chi-square
// and Kolmogorov-Smirnov against profiles written out independently here), the
// 1-px box reproduces the plain uniform jitter exactly, and the warp is monotone
// and symmetric.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <vector>

#include "chi2_test.h"
#include "ptir/core/error.h"
#include "ptir/math/pixel_filter.h"
#include "ptir/math/rng.h"

using namespace ptir;

namespace {

constexpr int kSamples = 1000000;
constexpr double kPiD = 3.14159265358979323846;

// Blackman-Harris window over [-R, R], peak at 0 (the textbook form, with the
// cosines' signs flipped by centring the window): Cycles' width w gives R = w.
double blackman_harris(double x, double R) {
  if (std::fabs(x) > R) return 0.0;
  double t = kPiD * x / R;
  return 0.35875 + 0.48829 * std::cos(t) + 0.14128 * std::cos(2 * t) + 0.01168 * std::cos(3 * t);
}
// Cycles' Gaussian of width w: sigma = w / 4, cut at 1.5 w.
double gaussian(double x, double w) { return std::fabs(x) > 1.5 * w ? 0.0 : std::exp(-0.5 * x * x / (w * w / 16.0)); }

// Integral of f over [a, b] by composite Simpson (fine enough to be exact here).
double integrate(const std::function<double(double)>& f, double a, double b, int n = 200) {
  double h = (b - a) / n, s = f(a) + f(b);
  for (int i = 1; i < n; ++i) s += f(a + i * h) * (i % 2 ? 4 : 2);
  return s * h / 3.0;
}

std::vector<double> offsets(const PixelFilterSampler& s, uint64_t seed) {
  std::vector<double> x(kSamples);
  for (int i = 0; i < kSamples; ++i) x[size_t(i)] = s.sample(Rng(seed, uint64_t(i)).at(0));
  return x;
}

// Chi-square over `bins` bins on [-lim, lim] and the KS distance to the profile's CDF.
void check_distribution(const PixelFilter& filter, const std::function<double(double)>& profile, double lim,
                        const char* what) {
  PixelFilterSampler s(filter);
  std::vector<double> x = offsets(s, 17);
  const int bins = 120;
  const double total = integrate(profile, -lim, lim, 20000);
  std::vector<double> obs(bins, 0.0), exp(bins, 0.0);
  for (double v : x) {
    int b = int((v + lim) / (2 * lim) * bins);
    ASSERT_TRUE(b >= 0 && b < bins) << what << ": offset " << v << " outside +-" << lim;
    obs[size_t(b)] += 1.0;
  }
  for (int b = 0; b < bins; ++b) {
    double a = -lim + 2 * lim * b / bins, c = a + 2 * lim / bins;
    exp[size_t(b)] = kSamples * integrate(profile, a, c) / total;
  }
  ptir::test::Chi2Result r = ptir::test::chi2_test(obs, exp);
  // KS: the empirical CDF against the profile's, at every sample.
  std::sort(x.begin(), x.end());
  double ks = 0.0, cdf = 0.0, at = -lim;
  for (size_t i = 0; i < x.size(); ++i) {
    cdf += integrate(profile, at, x[i], 8) / total;
    at = x[i];
    ks = std::max({ks, std::fabs(cdf - double(i) / kSamples), std::fabs(cdf - double(i + 1) / kSamples)});
  }
  const double ks_crit = 1.95 / std::sqrt(double(kSamples));  // alpha = 0.001
  std::printf("  %-36s %s KS=%.2e (crit %.2e)\n", what, r.summary().c_str(), ks, ks_crit);
  EXPECT_FALSE(r.impossible_sample) << what;
  EXPECT_GT(r.p_value, 1e-3) << what << ": " << r.summary();
  EXPECT_LT(ks, ks_crit) << what;
}

}  // namespace

TEST(PixelFilter, BlackmanHarrisMatchesTheAnalyticProfile) {
  // Blender's default (width 1.5): the window spans +-1.5 px.
  check_distribution({PixelFilterType::BlackmanHarris, 1.5f}, [](double x) { return blackman_harris(x, 1.5); }, 1.6,
                     "Blackman-Harris 1.5");
  check_distribution({PixelFilterType::BlackmanHarris, 0.7f}, [](double x) { return blackman_harris(x, 0.7); }, 0.8,
                     "Blackman-Harris 0.7");
}

TEST(PixelFilter, GaussianAndBoxMatchTheirProfiles) {
  check_distribution({PixelFilterType::Gaussian, 1.5f}, [](double x) { return gaussian(x, 1.5); }, 2.3, "Gaussian 1.5");
  // (Binned over exactly its support: the reference integrals must not straddle a jump.)
  check_distribution({PixelFilterType::Box, 2.0f}, [](double x) { return std::fabs(x) <= 1.0 ? 1.0 : 0.0; }, 1.0,
                     "box 2");
}

TEST(PixelFilter, RadiusAndStatistics) {
  PixelFilterSampler bh({PixelFilterType::BlackmanHarris, 1.5f});
  EXPECT_FLOAT_EQ(bh.radius(), 1.5f);
  // Variance of the Blackman-Harris offsets: integral x^2 w / integral w, computed independently.
  double var_ref = integrate([](double x) { return x * x * blackman_harris(x, 1.5); }, -1.5, 1.5, 4000) /
                   integrate([](double x) { return blackman_harris(x, 1.5); }, -1.5, 1.5, 4000);
  double m = 0, m2 = 0;
  for (double v : offsets(bh, 3)) m += v, m2 += v * v;
  m /= kSamples;
  m2 /= kSamples;
  EXPECT_NEAR(m, 0.0, 3e-3);
  EXPECT_NEAR(m2, var_ref, 3e-3 * var_ref + 1e-3);
  std::printf("  Blackman-Harris 1.5: offset std %.4f px (analytic %.4f)\n", std::sqrt(m2), std::sqrt(var_ref));
}

TEST(PixelFilter, WarpIsMonotoneAndSymmetric) {
  for (PixelFilterType t : {PixelFilterType::BlackmanHarris, PixelFilterType::Gaussian, PixelFilterType::Box}) {
    PixelFilterSampler s({t, 1.5f});
    float prev = -1e9f;
    for (int i = 0; i < 10000; ++i) {
      float u = (i + 0.5f) / 10000.0f;
      float v = s.sample(u);
      EXPECT_GE(v, prev) << pixel_filter_name(t) << " u=" << u;
      EXPECT_NEAR(v, -s.sample(1.0f - u), 2e-4f) << pixel_filter_name(t) << " u=" << u;
      EXPECT_LE(std::fabs(v), s.radius() + 1e-6f);
      prev = v;
    }
    EXPECT_NEAR(s.sample(0.5f), 0.0f, 1e-6f);
  }
}

TEST(PixelFilter, OnePixelBoxIsThePlainJitter) {
  // Width 0 is the 1-px box: pixel + u exactly (the renderer's earlier jitter, bit for bit).
  for (PixelFilter f : {PixelFilter{PixelFilterType::BlackmanHarris, 0.0f}, PixelFilter{PixelFilterType::Box, 1.0f}}) {
    PixelFilterSampler s(f);
    for (int i = 0; i < 1000; ++i) {
      float u = Rng(5, uint64_t(i)).at(0);
      EXPECT_EQ(s.position(37, u), 37.0f + u);
    }
  }
}

TEST(PixelFilter, RejectsBadInput) {
  EXPECT_THROW(PixelFilterSampler({PixelFilterType::BlackmanHarris, -1.0f}), Error);
  EXPECT_THROW(PixelFilterSampler({PixelFilterType::Gaussian, std::nanf("")}), Error);
  EXPECT_THROW(parse_pixel_filter("mitchell"), Error);
  EXPECT_EQ(parse_pixel_filter("blackman_harris"), PixelFilterType::BlackmanHarris);
}
