// Cycles' Principled BSDF v2 (material/principled_v2.h): closed-form spot values
// (the Specular IOR Level remap, Fresnel at normal incidence, F82 at 1/7, the
// energy-preserving Oren-Nayar albedo), white furnaces (against Cycles' own ggx_E
// table and the energy conservation Multiscatter GGX promises), sampling against
// the pdf (chi2), eval_pdf / sample consistency, the sampled estimator against
// quadrature, and the dual-number gradients against central finite differences.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include "bsdf_test_directions.h"
#include "chi2_test.h"
#include "ptir/material/bsdf.h"
#include "ptir/material/cycles_tables.h"
#include "ptir/math/rng.h"

using namespace ptir;
using ptir::test::Chi2Result;
using ptir::test::dir_at;
using ptir::test::random_dir;
using ptir::test::SphereBinning;

namespace {

constexpr double kPiD = ptir::test::kPiD;
constexpr BsdfKind kGGX = BsdfKind::PrincipledV2GGX, kMulti = BsdfKind::PrincipledV2MultiGGX;

MaterialParams v2_material(Vec3 base, float r, float m, float ior = 1.5f, float level = 0.5f, Vec3 tint = Vec3(1.0f),
                           float sigma = 0.0f) {
  MaterialParams p;
  p.albedo = base;
  p.roughness = r;
  p.metallic = m;
  p.ior = ior;
  p.specular_ior_level = level;
  p.specular_tint_color = tint;
  p.diffuse_roughness = sigma;
  return p;
}

ptir::test::QuadratureOptions lobe_quad(float roughness, Vec3 wo, double rel_tol = 1e-4) {
  const float r = std::max(roughness, kPrincipledMinRoughness);
  auto q = ptir::test::lobe_quadrature(Vec3(-wo.x, -wo.y, wo.z), r * r);
  q.rel_tol = rel_tol;
  return q;
}

double albedo_of(BsdfKind kind, const MaterialParams& p, Vec3 wo, int channel = 0) {
  Bsdf bsdf(kind, p, wo);
  return ptir::test::integrate_hemisphere([&](Vec3 wi) { return bsdf.eval(wi)[channel]; }, lobe_quad(p.roughness, wo));
}

double F0_of(double eta) { return ((eta - 1) / (eta + 1)) * ((eta - 1) / (eta + 1)); }

}  // namespace

// Specular IOR Level: F0 = 2 L F0(IOR), eta = (1 + sqrt F0) / (1 - sqrt F0); 0.5 leaves IOR alone, 0 removes the lobe.
TEST(PrincipledV2, SpecularIorLevelRemap) {
  for (double ior : {1.3, 1.5, 2.0, 0.8})
    for (double level : {0.0, 0.2, 0.25, 0.5, 0.8, 1.0}) {
      const SpecularIor s = specular_ior(float(ior), float(level));
      double F0 = F0_of(ior), eta = ior;
      if (level != 0.5) {
        F0 *= 2 * level;
        eta = (1 + std::sqrt(F0)) / (1 - std::sqrt(F0));
        if (ior < 1) eta = 1 / eta;
      }
      EXPECT_NEAR(s.F0, F0, 1e-6) << ior << " " << level;
      EXPECT_NEAR(s.eta, eta, 2e-5 * eta) << ior << " " << level;
    }
  // The examples of the spec (IOR 1.5): level 0.25 -> eta 1.32943, level 1 -> 1.78879; level 0 -> no lobe.
  EXPECT_NEAR(specular_ior(1.5f, 0.25f).eta, 1.32943, 1e-4);
  EXPECT_NEAR(specular_ior(1.5f, 1.0f).eta, 1.78879, 1e-4);
  EXPECT_EQ(specular_ior(1.5f, 0.0f).eta, 1.0f);
}

// At wo = wi = n the dielectric lobe is F0' D(n) G2 / 4 with D(n) = 1 / (pi alpha^2), G2 = 1:
// F0' = sat(2 L F0(IOR) tint) per channel (a black base has no diffuse).
TEST(PrincipledV2, FresnelAtNormalIncidenceWithLevelAndTint) {
  const Vec3 n(0, 0, 1);
  for (float level : {0.2f, 0.5f, 0.8f})
    for (float ior : {1.3f, 1.5f, 2.0f}) {
      const Vec3 tint(1.0f, 0.6f, 0.2f);
      const float r = 0.3f;
      const MaterialParams p = v2_material(Vec3(0.0f), r, 0.0f, ior, level, tint);
      const Vec3 f = Bsdf(kGGX, p, n).eval(n);
      const double alpha = double(r) * r;
      for (int c = 0; c < 3; ++c) {
        const double want = std::min(1.0, 2.0 * level * F0_of(ior) * tint[c]);
        EXPECT_NEAR(f[c] * 4 * kPiD * alpha * alpha, want, 2e-4 * want + 1e-7) << "ior " << ior << " level " << level;
      }
    }
}

// F82-tint: F(1/7) = F_Schlick(1/7) t (its definition), F(1) = F0, F(0) = 1.
TEST(PrincipledV2, F82TintAtOneSeventh) {
  for (float F0 : {0.05f, 0.5f, 0.95f})
    for (float t : {0.0f, 0.3f, 1.0f}) {
      const float B = fresnel_f82tint_B(F0, t);
      const double schlick = F0 + (1.0 - F0) * std::pow(6.0 / 7.0, 5.0);
      EXPECT_NEAR(fresnel_f82(1.0f / 7.0f, F0, B), std::min(1.0, schlick * t), 2e-6) << F0 << " " << t;
      EXPECT_NEAR(fresnel_f82(1.0f, F0, B), F0, 1e-7);
      EXPECT_NEAR(fresnel_f82(0.0f, F0, B), 1.0f, 1e-7);
    }
}

// Energy-preserving Oren-Nayar: the single-scatter albedo int (a + b t) n.wi dwi equals
// a pi + b G(mu) (quadrature of Fujii's lobe against the closed form), and the full
// lobe with a white base reflects everything (the point of its multiscatter term).
TEST(PrincipledV2, OrenNayarAlbedoClosedForm) {
  for (float sigma : {0.5f, 1.0f})
    for (float theta : {0.0f, 30.0f, 60.0f, 85.0f}) {
      const Vec3 wo = dir_at(theta);
      const double a = 1.0 / (kPiD + sigma * (kPiD / 2 - 2.0 / 3.0)), b = sigma * a;
      const double ss = ptir::test::integrate_hemisphere([&](Vec3 wi) {
        double t = dot(wo, wi) - double(wi.z) * wo.z;
        if (t > 0) t /= std::max(wi.z, wo.z);
        return float((a + b * t) * wi.z);
      });
      EXPECT_NEAR(ss, a * kPiD + b * oren_nayar_G(wo.z), 2e-4) << sigma << " " << theta;
      // White base, no specular lobe (level 0): a white furnace.
      const MaterialParams p = v2_material(Vec3(1.0f), 0.5f, 0.0f, 1.5f, 0.0f, Vec3(1.0f), sigma);
      EXPECT_NEAR(albedo_of(kGGX, p, wo), 1.0, 2e-3) << sigma << " " << theta;
    }
}

// White furnaces. A white GGX metal reflects Cycles' ggx_E(r, mu) (Cycles' own table
// values at its nodes, tests/data); with Multiscatter GGX it reflects 1. The layered
// dielectric over a white base prints its table; Multiscatter keeps it within 3 % of 1.
TEST(PrincipledV2, FurnaceTables) {
  const float angles[] = {0.0f, 30.0f, 60.0f, 75.0f, 85.0f};
  // Nodes of the 32 x 32 table (r = i / 31, mu = j / 31) and Cycles' values there.
  struct Node { int i, j; double cycles; } nodes[] = {{10, 31, 0.987261}, {20, 31, 0.770757}, {31, 31, 0.306853},
                                                      {20, 16, 0.746651}, {31, 16, 0.443841}, {10, 8, 0.920251}};
  for (const Node& nd : nodes) {
    const float r = nd.i / 31.0f, mu = nd.j / 31.0f;
    const Vec3 wo(std::sqrt(1 - mu * mu), 0, mu);
    const double e = albedo_of(kGGX, v2_material(Vec3(1.0f), r, 1.0f), wo);
    EXPECT_NEAR(e, nd.cycles, 2e-3) << "r=" << r << " mu=" << mu;
    EXPECT_NEAR(albedo_of(kMulti, v2_material(Vec3(1.0f), r, 1.0f), wo), 1.0, 1e-2) << "r=" << r << " mu=" << mu;
  }
  for (BsdfKind kind : {kGGX, kMulti}) {
    std::printf("  white furnace, dielectric (IOR 1.5) over a white base, %s (rows r, cols theta_o)\n    r \\ deg",
                kind == kGGX ? "GGX" : "Multiscatter GGX");
    for (float t : angles) std::printf(" %7.0f", t);
    std::printf("\n");
    for (float r : {0.1f, 0.3f, 0.6f, 0.9f}) {
      std::printf("    %6.2f ", r);
      for (float theta : angles) {
        const double e = albedo_of(kind, v2_material(Vec3(1.0f), r, 0.0f), dir_at(theta));
        std::printf(" %7.4f", e);
        EXPECT_LE(e, 1.0 + 3e-2);
        if (kind == kMulti) {
          EXPECT_GE(e, 1.0 - 3e-2) << "r=" << r << " theta=" << theta;
        }
      }
      std::printf("\n");
    }
  }
}

TEST(PrincipledV2, ReciprocalWhereCyclesIsAndZeroBelowHorizon) {
  const MaterialParams p = v2_material(Vec3(0.7f, 0.4f, 0.2f), 0.4f, 0.3f);
  for (BsdfKind kind : {kGGX, kMulti}) {
    Bsdf b(kind, p, dir_at(40));
    EXPECT_EQ(b.eval(Vec3(0.3f, 0.1f, -0.5f)).x, 0.0f);
    EXPECT_EQ(b.pdf(Vec3(0.3f, 0.1f, -0.5f)), 0.0f);
    Bsdf below(kind, p, Vec3(0.6f, 0.0f, -0.8f));
    EXPECT_EQ(below.eval(dir_at(20)).y, 0.0f);
    EXPECT_FALSE(below.sample(0.3f, 0.4f, 0.5f).valid);
  }
}

TEST(PrincipledV2, Chi2SampleMatchesPdf) {
  struct Case { float r, m, level; Vec3 tint; float sigma; } cases[] = {
      {0.1f, 0.0f, 0.5f, Vec3(1.0f), 0.0f}, {0.3f, 1.0f, 0.5f, Vec3(0.9f, 0.6f, 0.3f), 0.0f},
      {0.6f, 0.5f, 0.8f, Vec3(1.0f), 0.5f}, {0.9f, 0.0f, 0.2f, Vec3(0.5f, 1.0f, 0.5f), 1.0f},
      {0.3f, 0.0f, 0.0f, Vec3(1.0f), 0.0f}};
  const float angles[] = {10.0f, 45.0f, 80.0f};
  const double significance = ptir::test::sidak_significance(0.01, 2 * 5 * 3);
  SphereBinning b;
  b.cos_min = 0.0;
  for (BsdfKind kind : {kGGX, kMulti})
    for (const Case& c : cases)
      for (float theta : angles) {
        const MaterialParams p = v2_material(Vec3(0.9f, 0.5f, 0.1f), c.r, c.m, 1.5f, c.level, c.tint, c.sigma);
        const Vec3 wo = dir_at(theta);
        Bsdf bsdf(kind, p, wo);
        Rng rng(900 + int(kind), uint64_t(c.r * 1000) * 10 + uint64_t(c.m * 2), uint64_t(theta));
        double integral = 0;
        Chi2Result res = ptir::test::chi2_direction_test(
            b,
            [&](int k) {
              BsdfSample s = bsdf.sample(rng.at(3 * k), rng.at(3 * k + 1), rng.at(3 * k + 2));
              return std::pair{s.wi, s.valid};
            },
            [&](Vec3 wi) { return bsdf.pdf(wi); }, 400000, lobe_quad(c.r, wo), &integral);
        std::printf("  kind=%d r=%.1f m=%.1f wo=%2.0fdeg int(pdf)=%.6f %s\n", int(kind), c.r, c.m, theta, integral,
                    res.summary().c_str());
        EXPECT_FALSE(res.impossible_sample);
        EXPECT_GT(res.p_value, significance) << "r=" << c.r << " m=" << c.m << " theta=" << theta;
      }
}

// eval_pdf is eval and pdf; sample's weight is eval / pdf at its direction; the
// sampled estimator of int f~ matches quadrature of eval.
TEST(PrincipledV2, EvalPdfSampleConsistentAndUnbiased) {
  const Vec3 w(1.0f, 2.0f, 4.0f);
  Rng dirs(41);
  for (BsdfKind kind : {kGGX, kMulti})
    for (float r : {0.1f, 0.4f, 0.9f})
      for (float m : {0.0f, 0.5f, 1.0f})
        for (float theta : {10.0f, 60.0f, 85.0f}) {
          const MaterialParams p = v2_material(Vec3(0.8f, 0.5f, 0.2f), r, m, 1.45f, 0.7f, Vec3(1.0f, 0.8f, 0.6f), 0.3f);
          const Vec3 wo = dir_at(theta);
          Bsdf bsdf(kind, p, wo);
          for (int i = 0; i < 20; ++i) {
            const Vec3 wi = random_dir(dirs);
            const BsdfEvalPdf ep = bsdf.eval_pdf(wi);
            EXPECT_EQ(ep.pdf, bsdf.pdf(wi));
            EXPECT_EQ(ep.f.y, bsdf.eval(wi).y);
          }
          Rng rng(1000 + int(kind), uint64_t(r * 1000) * 10 + uint64_t(m * 2), uint64_t(theta));
          const int n = 200000;
          double sum = 0, sum2 = 0;
          for (int k = 0; k < n; ++k) {
            const BsdfSample s = bsdf.sample(rng.at(3 * k), rng.at(3 * k + 1), rng.at(3 * k + 2));
            if (!s.valid) continue;
            if (k % 1000 == 0) {
              const BsdfEvalPdf ep = bsdf.eval_pdf(s.wi);
              EXPECT_NEAR(s.pdf, ep.pdf, 1e-6f * ep.pdf);
              EXPECT_NEAR(s.weight.x, ep.f.x / ep.pdf, 1e-5f * s.weight.x + 1e-12f);
            }
            const double v = dot(w, s.weight);
            sum += v;
            sum2 += v * v;
          }
          const double q = ptir::test::integrate_hemisphere([&](Vec3 wi) { return dot(w, bsdf.eval(wi)); }, lobe_quad(r, wo));
          const double mean = sum / n, se = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
          EXPECT_NEAR(mean, q, 4 * se + 3e-4 * q + 1e-6) << "kind=" << int(kind) << " r=" << r << " m=" << m;
        }
}

namespace {

double adjoint_value(BsdfKind kind, const MaterialParams& p, Vec3 wo, Vec3 wi, Vec3 adj) {
  const Vec3 f = Bsdf(kind, p, wo).eval(wi);
  return double(adj.x) * f.x + double(adj.y) * f.y + double(adj.z) * f.z;
}

// Distance of x from the nearest node of an n-node grid on [0, 1], in node spacings.
float off_node(float x, int n) {
  const float u = x * float(n - 1);
  return std::fabs(u - std::round(u));
}

// Dual-number adjoints against central differences of the float evaluation (step
// 1e-3), tolerance as the v1 test: 1e-3 relative + float rounding + the
// step-doubling estimate of the truncation error. The tables' interpolants have
// kinks at their roughness nodes (32- and 16-node grids): differences straddling
// one average two slopes, so cases near a node are skipped.
void check_v2_gradients(BsdfKind kind, uint64_t seed) {
  Rng rng(seed);
  const float eps = std::numeric_limits<float>::epsilon();
  int n_checks = 0, n_sharp = 0;
  double worst_sharp = 0;
  for (int i = 0; i < 2000; ++i) {
    MaterialParams p = v2_material(Vec3(0.02f + 0.96f * rng.next(), 0.02f + 0.96f * rng.next(), 0.02f + 0.96f * rng.next()),
                                   0.05f + 0.93f * rng.next(), 0.02f + 0.96f * rng.next(), 1.1f + 1.2f * rng.next(),
                                   rng.next(), Vec3(0.2f + 0.8f * rng.next(), 0.2f + 0.8f * rng.next(), 1.0f),
                                   i % 2 ? rng.next() : 0.0f);
    if (i % 3 == 0) p.specular_tint_color = Vec3(1.0f);
    if (off_node(p.roughness, 32) < 0.1f || off_node(p.roughness, 16) < 0.1f) continue;
    const Vec3 wo = random_dir(rng, 0.05f);
    Vec3 wi = random_dir(rng, 0.05f);
    if (i % 2 == 0) {  // half the cases near the specular peak
      const Vec3 mirror(-wo.x, -wo.y, wo.z);
      wi = normalize(mirror + 0.3f * p.roughness * p.roughness * random_dir(rng));
      if (wi.z < 0.05f) continue;
    }
    const Vec3 adj(2 * rng.next() - 1, 2 * rng.next() - 1, 2 * rng.next() - 1);
    MaterialGrad g;
    const Vec3 f = Bsdf(kind, p, wo).eval_grad(wi, adj, g);
    const Vec3 f_plain = Bsdf(kind, p, wo).eval(wi);
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(f[c], f_plain[c], 1e-6f * std::fabs(f_plain[c]) + 1e-12f);
    const double mag = std::fabs(adj.x * f.x) + std::fabs(adj.y * f.y) + std::fabs(adj.z * f.z);
    auto check = [&](auto set, float value, double ana, const char* what) {
      const float h = 1e-3f;
      const float vp = value + h, vm = value - h, vp2 = value + 2 * h, vm2 = value - 2 * h;
      MaterialParams a = p, b = p, a2 = p, b2 = p;
      set(a, vp), set(b, vm), set(a2, vp2), set(b2, vm2);
      const double d1 = (adjoint_value(kind, a, wo, wi, adj) - adjoint_value(kind, b, wo, wi, adj)) / (double(vp) - double(vm));
      const double d2 = (adjoint_value(kind, a2, wo, wi, adj) - adjoint_value(kind, b2, wo, wi, adj)) / (double(vp2) - double(vm2));
      const double tol = 1e-3 * std::fabs(d1) + 8 * eps * mag / h + std::fabs(d1 - d2);
      EXPECT_NEAR(ana, d1, tol) << what << " kind=" << int(kind) << " r=" << p.roughness << " m=" << p.metallic
                                << " ior=" << p.ior << " level=" << p.specular_ior_level << " sigma=" << p.diffuse_roughness;
      if (std::fabs(d1) > 1e-7) ++n_checks;
      if (tol < 2e-3 * std::fabs(d1)) {
        ++n_sharp;
        worst_sharp = std::max(worst_sharp, std::fabs(ana - d1) / std::fabs(d1));
      }
    };
    for (int c = 0; c < 3; ++c)
      check([c](MaterialParams& q, float v) { q.albedo[c] = v; }, p.albedo[c], g.d_albedo[c], "base colour");
    check([](MaterialParams& q, float v) { q.roughness = v; }, p.roughness, g.d_roughness, "roughness");
    check([](MaterialParams& q, float v) { q.metallic = v; }, p.metallic, g.d_metallic, "metallic");
    if (::testing::Test::HasFailure()) break;
  }
  std::printf("  kind=%d: %d of %d checks sharp (tolerance < 2e-3 relative); worst relative error among them %.3g\n",
              int(kind), n_sharp, n_checks, worst_sharp);
  EXPECT_GT(n_sharp, n_checks / 5);
}

}  // namespace

TEST(PrincipledV2, GradientsMatchFiniteDifferences) { check_v2_gradients(kGGX, 51); }
TEST(PrincipledV2, MultiscatterGradientsMatchFiniteDifferences) { check_v2_gradients(kMulti, 52); }

TEST(PrincipledV2, NoNaNEver) {
  Rng rng(53);
  for (int i = 0; i < 100000; ++i) {
    MaterialParams p = v2_material(Vec3(rng.next(), rng.next(), rng.next()) * (i % 7 == 0 ? 0.0f : 1.0f),
                                   i % 5 == 0 ? 0.0f : rng.next(), i % 11 == 0 ? 1.0f : rng.next(),
                                   i % 9 == 0 ? 1.0f : 1.0f + 2.0f * rng.next(), i % 13 == 0 ? 0.0f : rng.next(),
                                   Vec3(rng.next(), rng.next(), rng.next()), i % 2 ? rng.next() : 0.0f);
    const Vec3 wo = random_dir(rng, i % 3 == 0 ? 0.0f : 1e-4f), wi = random_dir(rng);
    for (BsdfKind kind : {kGGX, kMulti}) {
      Bsdf bsdf(kind, p, wo);
      const BsdfSample s = bsdf.sample(rng.next(), rng.next(), rng.next());
      MaterialGrad g;
      const Vec3 f = bsdf.eval_grad(wi, Vec3(1.0f), g);
      ASSERT_TRUE(std::isfinite(f.x + f.y + f.z + bsdf.pdf(wi)));
      ASSERT_TRUE(std::isfinite(g.d_albedo.x + g.d_albedo.y + g.d_albedo.z + g.d_roughness + g.d_metallic));
      if (s.valid) {
        ASSERT_TRUE(std::isfinite(s.weight.x + s.weight.y + s.weight.z + s.pdf));
      }
    }
  }
}
