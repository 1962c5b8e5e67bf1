// Warping functions and MIS heuristics of math/sampling.h: chi-square
// goodness-of-fit of every sampler against its pdf, pdf normalisation,
// heuristic values, and the chi-square machinery itself.
#include <gtest/gtest.h>

#include <cstdio>

#include "chi2_test.h"
#include "ptir/math/rng.h"
#include "ptir/math/sampling.h"

using namespace ptir;
using ptir::test::chi2_direction_test;
using ptir::test::Chi2Result;
using ptir::test::SphereBinning;

namespace {

constexpr int kSamples = 1000000;
// Chi-square tests in this file: cosine hemisphere, uniform sphere, uniform
// hemisphere, GGX NDF x 4 alphas, GGX VNDF x 4 alphas x 3 angles.
constexpr int kNumChi2Tests = 3 + 4 + 12;
const double kSignificance = ptir::test::sidak_significance(0.01, kNumChi2Tests);

Vec3 dir_at(float theta_deg, float phi = 0.3f) {
  float t = theta_deg * kPi / 180.0f;
  return spherical_direction(std::sin(t), std::cos(t), phi);
}

void expect_pass(const Chi2Result& r, const char* what) {
  std::printf("  %-40s %s\n", what, r.summary().c_str());
  EXPECT_FALSE(r.impossible_sample) << what;
  EXPECT_GT(r.p_value, kSignificance) << what << ": " << r.summary();
}

}  // namespace

TEST(Chi2Math, IncompleteGammaKnownValues) {
  using ptir::test::chi2_sf;
  // 95% quantiles of chi2(dof) from tables.
  EXPECT_NEAR(chi2_sf(3.841458820694124, 1), 0.05, 1e-10);
  EXPECT_NEAR(chi2_sf(18.307038053275146, 10), 0.05, 1e-10);
  EXPECT_NEAR(chi2_sf(124.34211340400407, 100), 0.05, 1e-10);
  EXPECT_NEAR(chi2_sf(1074.6794273058687, 1000), 0.05, 1e-6);  // table value to ~1e-5 in x
  // 1% quantile side and both branches of the implementation.
  EXPECT_NEAR(chi2_sf(23.209251158954356, 10), 0.01, 1e-10);
  EXPECT_NEAR(chi2_sf(2.5582121601872063, 10), 0.99, 1e-10);
  // chi2(2) is exponential: sf = exp(-x / 2).
  for (double x : {0.01, 0.5, 2.0, 3.0, 10.0, 50.0}) EXPECT_NEAR(chi2_sf(x, 2), std::exp(-0.5 * x), 1e-12);
  // P + Q = 1; P(1, x) = 1 - exp(-x).
  for (double a : {0.5, 1.0, 7.5, 300.0})
    for (double x : {0.1, 1.0, 10.0, 299.0, 400.0})
      EXPECT_NEAR(ptir::test::gamma_p(a, x) + ptir::test::gamma_q(a, x), 1.0, 1e-12);
  EXPECT_NEAR(ptir::test::gamma_p(1.0, 1.7), 1.0 - std::exp(-1.7), 1e-14);
  EXPECT_NEAR(ptir::test::sidak_significance(0.01, 1), 0.01, 1e-15);
  EXPECT_LT(ptir::test::sidak_significance(0.01, 24), 0.01 / 23.0);
}

TEST(Chi2Math, PoolsSmallBinsAndFlagsImpossibleSamples) {
  // Perfect fit: statistic 0, p = 1.
  Chi2Result r = ptir::test::chi2_test({10, 20, 30, 40}, {10, 20, 30, 40});
  EXPECT_EQ(r.dof, 3);
  EXPECT_NEAR(r.statistic, 0.0, 1e-12);
  EXPECT_NEAR(r.p_value, 1.0, 1e-12);
  // Small bins pooled: {1, 2, 3} -> one bin of 6 observed vs 6 expected.
  r = ptir::test::chi2_test({1, 2, 3, 50, 50}, {1, 2, 3, 50, 50});
  EXPECT_EQ(r.pooled_bins, 3);
  EXPECT_EQ(r.dof, 2);
  // A sample where the density is zero is a failure.
  r = ptir::test::chi2_test({1, 50, 50}, {0, 50.5, 50.5});
  EXPECT_TRUE(r.impossible_sample);
  EXPECT_EQ(r.p_value, 0.0);
  // A clear misfit is rejected.
  r = ptir::test::chi2_test({700, 300}, {500, 500});
  EXPECT_LT(r.p_value, 1e-10);
}

TEST(Sampling, SphericalHelpers) {
  Rng rng(11);
  for (int i = 0; i < 1000; ++i) {
    Vec3 w = square_to_uniform_sphere(rng.next(), rng.next());
    EXPECT_NEAR(length(w), 1.0f, 1e-5f);
    float th = spherical_theta(w), ph = spherical_phi(w);
    EXPECT_GE(ph, 0.0f);
    EXPECT_LT(ph, 2 * kPi);
    Vec3 back = spherical_direction(std::sin(th), std::cos(th), ph);
    EXPECT_NEAR(back.x, w.x, 1e-5f);
    EXPECT_NEAR(back.y, w.y, 1e-5f);
    EXPECT_NEAR(back.z, w.z, 1e-5f);
    Vec3 n = square_to_uniform_sphere(rng.next(), rng.next());
    Vec3 r = reflect(w, n);
    EXPECT_NEAR(length(r), 1.0f, 1e-5f);
    EXPECT_NEAR(dot(r, n), dot(w, n), 1e-5f);
  }
  float x, y;
  for (float u1 : {0.0f, 0.25f, 0.5f, 0.9999999f})
    for (float u2 : {0.0f, 0.5f, 0.75f, 0.9999999f}) {
      square_to_concentric_disk(u1, u2, x, y);
      EXPECT_LE(x * x + y * y, 1.0f + 1e-6f);
      Vec3 w = square_to_cosine_hemisphere(u1, u2);
      EXPECT_TRUE(is_finite(w));
      EXPECT_GE(w.z, 0.0f);
      EXPECT_NEAR(length(w), 1.0f, 1e-5f);
    }
}

TEST(Sampling, PowerHeuristicValues) {
  EXPECT_FLOAT_EQ(power_heuristic(1, 0.5f, 1, 0.5f), 0.5f);
  EXPECT_FLOAT_EQ(power_heuristic(1, 2.0f, 1, 1.0f), 0.8f);
  EXPECT_FLOAT_EQ(power_heuristic(1, 1.0f, 1, 2.0f), 0.2f);
  EXPECT_FLOAT_EQ(power_heuristic(1, 3.0f, 1, 4.0f), 9.0f / 25.0f);
  EXPECT_FLOAT_EQ(power_heuristic(2, 1.0f, 1, 1.0f), 0.8f);  // sample counts scale the pdfs
  EXPECT_FLOAT_EQ(power_heuristic(1, 1.0f, 1, 0.0f), 1.0f);
  EXPECT_FLOAT_EQ(power_heuristic(1, 0.0f, 1, 1.0f), 0.0f);
  EXPECT_FLOAT_EQ(power_heuristic(1, 0.0f, 1, 0.0f), 0.0f);  // no 0/0
  // Overflow of the squares: the dominant strategy takes the weight, weights sum to 1.
  EXPECT_FLOAT_EQ(power_heuristic(1, 1e30f, 1, 1.0f), 1.0f);
  EXPECT_FLOAT_EQ(power_heuristic(1, 1.0f, 1, 1e30f), 0.0f);
  const float inf = std::numeric_limits<float>::infinity();
  EXPECT_FLOAT_EQ(power_heuristic(1, inf, 1, 1.0f), 1.0f);
  EXPECT_FLOAT_EQ(power_heuristic(1, inf, 1, inf) + power_heuristic(1, inf, 1, inf), 1.0f);
  // Complementarity on random inputs.
  Rng rng(5);
  for (int i = 0; i < 1000; ++i) {
    float a = std::exp(20.0f * (rng.next() - 0.5f)), b = std::exp(20.0f * (rng.next() - 0.5f));
    EXPECT_NEAR(power_heuristic(1, a, 1, b) + power_heuristic(1, b, 1, a), 1.0f, 1e-6f);
    EXPECT_NEAR(balance_heuristic(1, a, 1, b) + balance_heuristic(1, b, 1, a), 1.0f, 1e-6f);
    EXPECT_NEAR(balance_heuristic(1, a, 1, b), a / (a + b), 1e-6f);
  }
}

TEST(Sampling, Chi2CosineHemisphereAndSpheres) {
  SphereBinning b;  // 20 x 40 over the whole sphere
  Rng rng(101);
  auto u = [&](int k, int d) { return rng.at(uint64_t(k) * 2 + d); };
  expect_pass(chi2_direction_test(
                  b, [&](int k) { return std::pair{square_to_cosine_hemisphere(u(k, 0), u(k, 1)), true}; },
                  [](Vec3 w) { return cosine_hemisphere_pdf(w.z); }, kSamples),
              "cosine hemisphere");
  Rng rng2(102);
  expect_pass(chi2_direction_test(
                  b,
                  [&](int k) {
                    return std::pair{square_to_uniform_sphere(rng2.at(2 * k), rng2.at(2 * k + 1)), true};
                  },
                  [](Vec3) { return uniform_sphere_pdf(); }, kSamples),
              "uniform sphere");
  Rng rng3(103);
  expect_pass(chi2_direction_test(
                  b,
                  [&](int k) {
                    return std::pair{square_to_uniform_hemisphere(rng3.at(2 * k), rng3.at(2 * k + 1)), true};
                  },
                  [](Vec3 w) { return uniform_hemisphere_pdf(w.z); }, kSamples),
              "uniform hemisphere");
}

TEST(Sampling, Chi2GgxNormalDistribution) {
  SphereBinning b;
  b.cos_min = 0.0;  // half vectors live in the upper hemisphere: 20 x 40 bins there
  for (float r : {0.05f, 0.2f, 0.5f, 1.0f}) {
    float alpha = r * r;
    Rng rng(200, uint64_t(r * 1000));
    char name[64];
    std::snprintf(name, sizeof name, "GGX NDF alpha=%.4f", alpha);
    expect_pass(chi2_direction_test(
                    b, [&](int k) { return std::pair{sample_ggx_ndf(alpha, rng.at(2 * k), rng.at(2 * k + 1)), true}; },
                    [&](Vec3 h) { return ggx_ndf_pdf(h, alpha); }, kSamples, ptir::test::lobe_quadrature(Vec3(0, 0, 1), alpha)),
                name);
  }
}

TEST(Sampling, Chi2GgxVisibleNormals) {
  SphereBinning b;
  b.cos_min = 0.0;
  for (float r : {0.05f, 0.2f, 0.5f, 1.0f})
    for (float theta : {10.0f, 45.0f, 80.0f}) {
      float alpha = r * r;
      Vec3 wo = dir_at(theta);
      Rng rng(300, uint64_t(r * 1000), uint64_t(theta));
      char name[64];
      std::snprintf(name, sizeof name, "GGX VNDF alpha=%.4f wo=%.0fdeg", alpha, theta);
      expect_pass(chi2_direction_test(
                      b,
                      [&](int k) {
                        Vec3 h = sample_ggx_vndf(wo, alpha, rng.at(2 * k), rng.at(2 * k + 1));
                        return std::pair{h, h.z > 0.0f};
                      },
                      [&](Vec3 h) { return ggx_vndf_pdf(wo, h, alpha); }, kSamples / 2,
                      ptir::test::lobe_quadrature(Vec3(0, 0, 1), alpha)),
                  name);
    }
}

TEST(Sampling, PdfsIntegrateToOne) {
  using ptir::test::integrate_hemisphere;
  using ptir::test::lobe_quadrature;
  // Adaptive 3x3 Gauss-Legendre on (theta, phi) cells (relative tolerance 1e-7 per
  // cell); sharp lobes are resolved by forcing cells near the peak down to alpha/4.
  // Tolerance 1e-5 for all alphas, including alpha = 0.0025 (roughness clamp).
  EXPECT_NEAR(integrate_hemisphere([](Vec3 w) { return cosine_hemisphere_pdf(w.z); }), 1.0, 1e-6);
  EXPECT_NEAR(integrate_hemisphere([](Vec3 w) { return uniform_hemisphere_pdf(w.z); }), 1.0, 1e-6);
  for (float r : {0.05f, 0.1f, 0.2f, 0.5f, 1.0f}) {
    float alpha = r * r;
    auto q = lobe_quadrature(Vec3(0, 0, 1), alpha);
    EXPECT_NEAR(integrate_hemisphere([&](Vec3 h) { return ggx_ndf_pdf(h, alpha); }, q), 1.0, 1e-5)
        << "alpha " << alpha;
    for (float theta : {0.0f, 30.0f, 60.0f, 85.0f}) {
      Vec3 wo = dir_at(theta);
      EXPECT_NEAR(integrate_hemisphere([&](Vec3 h) { return ggx_vndf_pdf(wo, h, alpha); }, q), 1.0, 1e-5)
          << "alpha " << alpha << " theta " << theta;
    }
  }
}
