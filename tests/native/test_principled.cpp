// Cycles' Principled BSDF v1 and the Diffuse BSDF node (material/principled_bsdf.h,
// material/oren_nayar.h): values against a double-precision transcription of
// Cycles' v3.4 formulas (written the way Cycles writes them: D and G1 through
// tan^2), sampling against pdf (chi2), the sampled estimator against quadrature,
// directional-albedo tables (white furnace, energy compensation, the ratios that
// ../shared/docs/PRINCIPLED.md measured for docs/method.md §4's simplified Disney model), the energy table
// against quadrature, and analytic material derivatives against finite differences.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <limits>

#include "bsdf_test_directions.h"
#include "chi2_test.h"
#include "ptir/material/bsdf.h"
#include "ptir/material/ggx_energy.h"
#include "ptir/math/rng.h"

using namespace ptir;
using ptir::test::Chi2Result;
using ptir::test::SphereBinning;

namespace {

constexpr double kPiD = ptir::test::kPiD;

struct D3 {
  double x, y, z;
};
D3 d3(Vec3 v) { return {v.x, v.y, v.z}; }
double ddot(D3 a, D3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

double ref_fresnel(double cosi, double eta) {
  double c = std::fabs(cosi), g = eta * eta - 1 + c * c;
  if (g <= 0) return 1;
  g = std::sqrt(g);
  double A = (g - c) / (g + c), B = (c * (g + c) - 1) / (c * (g - c) + 1);
  return 0.5 * A * A * (1 + B * B);
}

// Height-correlated single-scattering GGX without Fresnel, D G2 / (4 n.V) (as f~):
// the single-scattering part of Cycles' Multiscatter GGX.
double ref_ggx_hc(double alpha, D3 V, D3 L) {
  if (V.z <= 0 || L.z <= 0) return 0;
  D3 Hs{V.x + L.x, V.y + L.y, V.z + L.z};
  double hl = std::sqrt(ddot(Hs, Hs));
  double c = Hs.z / hl, c2 = c * c, a2 = alpha * alpha;
  double D = a2 / (kPiD * std::pow(c2 * (a2 - 1) + 1, 2));
  auto lambda = [&](double z) { return 0.5 * (std::sqrt(1 + a2 * (1 - z * z) / (z * z)) - 1); };
  return D / (1 + lambda(V.z) + lambda(L.z)) / (4 * V.z);
}

// Cycles v3.4: principled diffuse + GGX with Fresnel (single scattering), as f~ = f cos_i.
// multiscatter: the height-correlated single-scattering lobe times 1 + cspec0 (1 - E) / E,
// with E from the library's table (tested against quadrature on its own below).
std::array<double, 3> ref_principled(const MaterialParams& p, D3 V, D3 L, bool multiscatter = false) {
  std::array<double, 3> out{0, 0, 0};
  if (V.z <= 0 || L.z <= 0) return out;
  const double b[3] = {p.albedo.x, p.albedo.y, p.albedo.z};
  const double m = p.metallic, s = p.specular, t = p.specular_tint, r = p.roughness;
  // Diffuse (bsdf_principled_diffuse.h).
  auto schlick = [](double u) { return std::pow(std::clamp(1 - u, 0.0, 1.0), 5); };
  double FV = schlick(V.z), FL = schlick(L.z);
  double RR = r * (ddot(L, V) + 1);
  double fd = (1 - 0.5 * FV) * (1 - 0.5 * FL) + RR * (FL + FV + FL * FV * (RR - 1));
  double diffuse = fd * L.z / kPiD;
  // Specular (closure.h + bsdf_microfacet.h eval_reflect).
  double rs = std::max(r, 0.02), alpha2 = rs * rs * rs * rs;
  double eta = 2 / (1 - std::sqrt(0.08 * s)) - 1;
  double lum = 0.3 * b[0] + 0.6 * b[1] + 0.1 * b[2];
  D3 Hs{V.x + L.x, V.y + L.y, V.z + L.z};
  double hl = std::sqrt(ddot(Hs, Hs));
  D3 H{Hs.x / hl, Hs.y / hl, Hs.z / hl};
  double cosThetaM = H.z, c2 = cosThetaM * cosThetaM, c4 = c2 * c2, tan2 = (1 - c2) / c2;
  double D = 1 / (kPiD * alpha2 * c4 * (1 + tan2 / alpha2) * (1 + tan2 / alpha2));
  double G1o = 2 / (1 + std::sqrt(1 + alpha2 * (1 - V.z * V.z) / (V.z * V.z)));
  double G1i = 2 / (1 + std::sqrt(1 + alpha2 * (1 - L.z * L.z) / (L.z * L.z)));
  double common = D * 0.25 / V.z;
  double F0 = ref_fresnel(1, eta);
  double FH = (ref_fresnel(ddot(L, H), eta) - F0) / (1 - F0);
  for (int c = 0; c < 3; ++c) {
    double tint = lum > 0 ? b[c] / lum : 1;
    double cspec0 = std::clamp(s * 0.08 * ((1 - t) + tint * t) * (1 - m) + b[c] * m, 0.0, 1.0);
    double F = cspec0 * (1 - FH) + FH;
    out[c] = (1 - m) * b[c] * diffuse + F * G1o * G1i * common;
    if (multiscatter && r > 0.075) {
      double E = ggx_energy(float(V.z), float(rs)).E;
      out[c] = (1 - m) * b[c] * diffuse + F * ref_ggx_hc(rs * rs, V, L) * (1 + cspec0 * (1 - E) / E);
    }
  }
  return out;
}

std::array<double, 3> ref_oren_nayar(const MaterialParams& p, D3 V, D3 L) {
  if (V.z <= 0 || L.z <= 0) return {0, 0, 0};
  double sigma = std::clamp(double(p.roughness), 0.0, 1.0);
  double A = 1 / (kPiD + (3 * kPiD - 4) / 6 * sigma), B = sigma * A;
  double s = ddot(L, V) - L.z * V.z;
  double tt = s > 0 ? s / std::max(L.z, V.z) : s;
  double v = L.z * (A + B * tt);
  return {p.albedo.x * v, p.albedo.y * v, p.albedo.z * v};
}

using ptir::test::dir_at;
using ptir::test::random_dir;

MaterialParams random_material(Rng& rng) {
  MaterialParams p;
  p.albedo = Vec3(0.02f + 0.96f * rng.next(), 0.02f + 0.96f * rng.next(), 0.02f + 0.96f * rng.next());
  p.roughness = 0.05f + 0.93f * rng.next();
  p.metallic = 0.02f + 0.96f * rng.next();
  p.specular = 0.05f + 0.9f * rng.next();
  p.specular_tint = rng.next();
  return p;
}

ptir::test::QuadratureOptions lobe_quad(float roughness, Vec3 wo, double rel_tol = 1e-4) {
  float r = std::max(roughness, kPrincipledMinRoughness);
  auto q = ptir::test::lobe_quadrature(Vec3(-wo.x, -wo.y, wo.z), r * r);
  q.rel_tol = rel_tol;
  return q;
}

double albedo_of(BsdfKind kind, const MaterialParams& p, Vec3 wo, int channel = 0) {
  Bsdf bsdf(kind, p, wo);
  return ptir::test::integrate_hemisphere([&](Vec3 wi) { return bsdf.eval(wi)[channel]; }, lobe_quad(p.roughness, wo));
}

}  // namespace

TEST(PrincipledBsdf, EvalMatchesCyclesFormula) {
  Rng rng(11);
  double worst = 0;
  for (int i = 0; i < 20000; ++i) {
    MaterialParams p = random_material(rng);
    Vec3 wo = random_dir(rng, 0.02f), wi = random_dir(rng, 0.02f);
    PrincipledBsdf bsdf(p, wo, false);
    Vec3 f = bsdf.eval(wi);
    auto ref = ref_principled(p, d3(wo), d3(wi));
    for (int c = 0; c < 3; ++c) {
      double err = std::fabs(f[c] - ref[c]) / std::max(ref[c], 1e-3);
      worst = std::max(worst, err);
      ASSERT_LT(err, 2e-4) << "c=" << c << " r=" << p.roughness << " m=" << p.metallic << " f=" << f[c]
                           << " ref=" << ref[c];
    }
  }
  std::printf("  worst relative error vs double Cycles transcription: %.3g\n", worst);
}

TEST(PrincipledBsdf, MultiscatterEvalMatchesReference) {
  Rng rng(14);
  double worst = 0;
  for (int i = 0; i < 20000; ++i) {
    MaterialParams p = random_material(rng);
    Vec3 wo = random_dir(rng, 0.02f), wi = random_dir(rng, 0.02f);
    Vec3 f = PrincipledBsdf(p, wo, true).eval(wi);
    auto ref = ref_principled(p, d3(wo), d3(wi), true);
    for (int c = 0; c < 3; ++c) {
      double err = std::fabs(f[c] - ref[c]) / std::max(ref[c], 1e-3);
      worst = std::max(worst, err);
      ASSERT_LT(err, 2e-4) << "c=" << c << " r=" << p.roughness << " m=" << p.metallic;
    }
  }
  std::printf("  worst relative error vs double reference: %.3g\n", worst);
}

TEST(PrincipledBsdf, DefaultsGiveIorOneAndAHalf) {
  EXPECT_NEAR(specular_to_eta(0.5f), 1.5f, 1e-6f);
  EXPECT_NEAR(fresnel_dielectric(1.0f, 1.5f), 0.04f, 1e-6f);
  // F0 = 0.08 s in general (PRINCIPLED.md).
  for (float s : {0.1f, 0.2f, 0.8f, 1.0f}) EXPECT_NEAR(fresnel_dielectric(1.0f, specular_to_eta(s)), 0.08f * s, 1e-5f);
}

TEST(PrincipledBsdf, ReciprocalAndZeroBelowHorizon) {
  Rng rng(12);
  for (int i = 0; i < 5000; ++i) {
    MaterialParams p = random_material(rng);
    Vec3 a = random_dir(rng, 0.05f), b = random_dir(rng, 0.05f);
    // f~(a, b) / cos b = f~(b, a) / cos a for the single-scattering model.
    Vec3 fab = PrincipledBsdf(p, a, false).eval(b) / b.z, fba = PrincipledBsdf(p, b, false).eval(a) / a.z;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(fab[c], fba[c], 2e-4f * std::max(1.0f, fab[c]));
    Vec3 below(b.x, b.y, -b.z);
    EXPECT_EQ(max_component(PrincipledBsdf(p, a, false).eval(below)), 0.0f);
    EXPECT_EQ(PrincipledBsdf(p, a, false).pdf(below), 0.0f);
  }
}

TEST(PrincipledBsdf, Chi2SampleMatchesPdf) {
  const float roughness[] = {0.1f, 0.3f, 0.6f, 0.9f};
  const float metallic[] = {0.0f, 1.0f};
  const float angles[] = {10.0f, 45.0f, 80.0f};
  const int n_tests = 4 * 2 * 3 * 2;
  const double significance = ptir::test::sidak_significance(0.01, n_tests);
  SphereBinning b;
  b.cos_min = 0.0;
  for (BsdfKind kind : {BsdfKind::PrincipledGGX, BsdfKind::OrenNayar})
    for (float r : roughness)
      for (float m : metallic)
        for (float theta : angles) {
          MaterialParams p{Vec3(0.9f, 0.5f, 0.1f), r, m, 0.5f, 0.0f};
          Vec3 wo = dir_at(theta);
          Bsdf bsdf(kind, p, wo);
          Rng rng(700 + int(kind), uint64_t(r * 1000) * 10 + uint64_t(m), uint64_t(theta));
          double integral = 0;
          Chi2Result res = ptir::test::chi2_direction_test(
              b,
              [&](int k) {
                BsdfSample s = bsdf.sample(rng.at(3 * k), rng.at(3 * k + 1), rng.at(3 * k + 2));
                return std::pair{s.wi, s.valid};
              },
              [&](Vec3 wi) { return bsdf.pdf(wi); }, 1000000, lobe_quad(r, wo), &integral);
          std::printf("  kind=%d r=%.2f m=%.0f wo=%2.0fdeg int(pdf)=%.6f %s\n", int(kind), r, m, theta, integral,
                      res.summary().c_str());
          EXPECT_FALSE(res.impossible_sample);
          EXPECT_GT(res.p_value, significance) << "r=" << r << " m=" << m << " theta=" << theta;
        }
}

TEST(PrincipledBsdf, SampledEstimateMatchesQuadratureOfEval) {
  const Vec3 w(1.0f, 2.0f, 4.0f);
  for (BsdfKind kind : {BsdfKind::PrincipledGGX, BsdfKind::PrincipledMultiGGX, BsdfKind::OrenNayar})
    for (float r : {0.1f, 0.3f, 0.6f, 0.9f})
      for (float m : {0.0f, 0.5f, 1.0f})
        for (float theta : {10.0f, 45.0f, 80.0f}) {
          MaterialParams p{Vec3(0.8f, 0.5f, 0.2f), r, m, 0.8f, 0.5f};
          Vec3 wo = dir_at(theta);
          Bsdf bsdf(kind, p, wo);
          Rng rng(800 + int(kind), uint64_t(r * 1000) * 10 + uint64_t(m * 2), uint64_t(theta));
          const int n = 200000;
          double sum = 0, sum2 = 0;
          for (int k = 0; k < n; ++k) {
            BsdfSample s = bsdf.sample(rng.at(3 * k), rng.at(3 * k + 1), rng.at(3 * k + 2));
            if (!s.valid) continue;
            double v = dot(w, s.weight);
            sum += v;
            sum2 += v * v;
          }
          double q = ptir::test::integrate_hemisphere([&](Vec3 wi) { return dot(w, bsdf.eval(wi)); }, lobe_quad(r, wo));
          double mean = sum / n, se = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
          EXPECT_NEAR(mean, q, 4 * se + 3e-4 * q + 1e-6) << "kind=" << int(kind) << " r=" << r << " m=" << m;
        }
}

TEST(PrincipledBsdf, EnergyTableMatchesQuadrature) {
  // E(mu, r) is the integral of the height-correlated lobe D G2 / (4 mu_o) (no Fresnel).
  double worst = 0;
  for (float r : {0.1f, 0.25f, 0.5f, 0.77f, 1.0f})
    for (float theta : {0.0f, 30.0f, 60.0f, 75.0f, 85.0f}) {
      Vec3 wo = dir_at(theta);
      double q = ptir::test::integrate_hemisphere([&](Vec3 wi) { return ref_ggx_hc(double(r) * r, d3(wo), d3(wi)); },
                                                  lobe_quad(r, wo));
      double e = ggx_energy(wo.z, r).E;
      worst = std::max(worst, std::fabs(e - q));
      EXPECT_NEAR(e, q, 3e-3) << "r=" << r << " theta=" << theta;
    }
  std::printf("  worst |table - quadrature| = %.2g\n", worst);
}

TEST(PrincipledBsdf, FurnaceTables) {
  const float roughness[] = {0.1f, 0.3f, 0.5f, 0.8f, 1.0f};
  const float angles[] = {0.0f, 30.0f, 45.0f, 60.0f, 75.0f, 85.0f};
  struct Row {
    const char* name;
    BsdfKind kind;
    float m;
  } rows[] = {{"dielectric GGX", BsdfKind::PrincipledGGX, 0.0f},
              {"metal GGX", BsdfKind::PrincipledGGX, 1.0f},
              {"metal Multiscatter GGX", BsdfKind::PrincipledMultiGGX, 1.0f},
              {"Diffuse BSDF (Oren-Nayar)", BsdfKind::OrenNayar, 0.0f}};
  for (const Row& row : rows) {
    std::printf("  directional albedo, base colour 1, %s (rows roughness, cols theta_o)\n    r \\ deg", row.name);
    for (float t : angles) std::printf(" %7.0f", t);
    std::printf("\n");
    for (float r : roughness) {
      std::printf("    %6.2f ", r);
      for (float theta : angles) {
        MaterialParams p{Vec3(1.0f), r, row.m};
        double e = albedo_of(row.kind, p, dir_at(theta));
        std::printf(" %7.4f", e);
        if (row.kind == BsdfKind::PrincipledGGX && row.m == 1.0f) {
          EXPECT_LE(e, 1.0 + 1e-4);
        }
        // Energy compensation restores a white metal to 1 (up to the table's interpolation).
        if (row.kind == BsdfKind::PrincipledMultiGGX) {
          EXPECT_NEAR(e, 1.0, 1.2e-2) << "r=" << r << " theta=" << theta;
        }
        if (row.kind == BsdfKind::OrenNayar) {
          EXPECT_LE(e, 1.0 + 1e-4);
        }
      }
      std::printf("\n");
    }
  }
  // Lambert limit of the Diffuse BSDF: roughness 0 reflects exactly the base colour.
  EXPECT_NEAR(albedo_of(BsdfKind::OrenNayar, MaterialParams{Vec3(1.0f), 0.0f, 0.0f}, dir_at(40)), 1.0, 1e-4);
}

TEST(PrincipledBsdf, MethodModelRatiosMatchPrinciplesDoc) {
  // ../shared/docs/PRINCIPLED.md measured docs/method.md §4's simplified Disney model / Cycles GGX directional
  // albedo by numerical integration; these are independent numbers, reproduced here.
  struct Case {
    float b, r, m, theta, ratio;
  } cases[] = {{0.8f, 0.5f, 0.0f, 0.0f, 0.955f}, {0.8f, 0.8f, 0.0f, 45.0f, 0.93f},
               {0.8f, 0.8f, 0.0f, 75.0f, 0.84f}, {0.9f, 0.5f, 1.0f, 45.0f, 0.92f},
               {0.9f, 0.5f, 1.0f, 75.0f, 0.81f}, {0.9f, 0.2f, 1.0f, 0.0f, 1.00f}};
  for (const Case& c : cases) {
    MaterialParams p{Vec3(c.b), c.r, c.m};
    Vec3 wo = dir_at(c.theta);
    double ours = albedo_of(BsdfKind::PrincipledGGX, p, wo);
    double method = albedo_of(BsdfKind::DisneySimplified, p, wo);
    std::printf("  b=%.1f r=%.1f m=%.0f theta=%2.0f  METHOD/Cycles = %.3f (doc %.3f)\n", c.b, c.r, c.m, c.theta,
                method / ours, c.ratio);
    EXPECT_NEAR(method / ours, c.ratio, 0.012);
  }
}

TEST(OrenNayarBsdf, EvalMatchesCyclesFormula) {
  Rng rng(13);
  for (int i = 0; i < 10000; ++i) {
    MaterialParams p = random_material(rng);
    p.roughness = i % 10 == 0 ? 0.0f : rng.next();
    Vec3 wo = random_dir(rng, 0.02f), wi = random_dir(rng, 0.02f);
    Vec3 f = OrenNayarBsdf(p, wo).eval(wi);
    auto ref = ref_oren_nayar(p, d3(wo), d3(wi));
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(f[c], ref[c], 1e-6 + 1e-5 * ref[c]);
  }
}

namespace {

double adjoint_value(BsdfKind kind, const MaterialParams& p, Vec3 wo, Vec3 wi, Vec3 adj) {
  Vec3 f = Bsdf(kind, p, wo).eval(wi);
  return double(adj.x) * f.x + double(adj.y) * f.y + double(adj.z) * f.z;
}

// Central differences of the float implementation (step 1e-3) against the analytic
// adjoint; tolerance: 1e-3 relative + float rounding + the step-doubling estimate
// of truncation error (as test_brdf.cpp). Returns the worst sharp relative error.
void check_gradients(BsdfKind kind, uint64_t seed, double rel_tol = 1e-3) {
  Rng rng(seed);
  const float eps = std::numeric_limits<float>::epsilon();
  int n_checks = 0, n_sharp = 0;
  double worst_sharp = 0;
  for (int i = 0; i < 3000; ++i) {
    MaterialParams p = random_material(rng);
    if (i % 3 == 0) p.specular_tint = 0.0f;
    // The compensation table's interpolant has kinks in roughness at its nodes:
    // finite differences straddling one average two slopes. Stay clear of them.
    const float node = p.roughness * float(kGgxEnergySize - 1);
    if (kind == BsdfKind::PrincipledMultiGGX && std::fabs(node - std::round(node)) < 0.1f) continue;
    // ... and of the switch to single scattering at r = 0.075 (a step, as in Cycles).
    if (kind == BsdfKind::PrincipledMultiGGX && std::fabs(p.roughness - kMultiscatterMinRoughness) < 3e-3f) continue;
    Vec3 wo = random_dir(rng, 0.05f), wi = random_dir(rng, 0.05f);
    if (i % 2 == 0) {  // half the cases near the specular peak
      Vec3 mirror(-wo.x, -wo.y, wo.z);
      wi = normalize(mirror + 0.3f * p.roughness * p.roughness * random_dir(rng));
      if (wi.z < 0.05f) continue;
    }
    Vec3 adj(2 * rng.next() - 1, 2 * rng.next() - 1, 2 * rng.next() - 1);
    MaterialGrad g;
    Vec3 f = Bsdf(kind, p, wo).eval_grad(wi, adj, g);
    double mag = std::fabs(adj.x * f.x) + std::fabs(adj.y * f.y) + std::fabs(adj.z * f.z);
    auto check = [&](auto set, float value, double ana, const char* what) {
      const float h = 1e-3f;
      float vp = value + h, vm = value - h, vp2 = value + 2 * h, vm2 = value - 2 * h;
      MaterialParams a = p, b = p, a2 = p, b2 = p;
      set(a, vp), set(b, vm), set(a2, vp2), set(b2, vm2);
      double d1 = (adjoint_value(kind, a, wo, wi, adj) - adjoint_value(kind, b, wo, wi, adj)) / (double(vp) - double(vm));
      double d2 =
          (adjoint_value(kind, a2, wo, wi, adj) - adjoint_value(kind, b2, wo, wi, adj)) / (double(vp2) - double(vm2));
      double tol = rel_tol * std::fabs(d1) + 8 * eps * mag / h + std::fabs(d1 - d2);
      EXPECT_NEAR(ana, d1, tol) << what << " kind=" << int(kind) << " r=" << p.roughness << " m=" << p.metallic
                                << " s=" << p.specular << " t=" << p.specular_tint;
      if (std::fabs(d1) > 1e-7) ++n_checks;  // (zero derivatives, e.g. Oren-Nayar's metallic, cannot be sharp)
      if (tol < 2e-3 * std::fabs(d1)) {
        ++n_sharp;
        worst_sharp = std::max(worst_sharp, std::fabs(ana - d1) / std::fabs(d1));
      }
    };
    for (int c = 0; c < 3; ++c)
      check([c](MaterialParams& q, float v) { q.albedo[c] = v; }, p.albedo[c], g.d_albedo[c], "albedo");
    check([](MaterialParams& q, float v) { q.roughness = v; }, p.roughness, g.d_roughness, "roughness");
    check([](MaterialParams& q, float v) { q.metallic = v; }, p.metallic, g.d_metallic, "metallic");
    if (::testing::Test::HasFailure()) break;
  }
  std::printf("  kind=%d: %d of %d checks sharp (tolerance < 2e-3 relative); worst relative error among them %.3g\n",
              int(kind), n_sharp, n_checks, worst_sharp);
  EXPECT_GT(n_sharp, n_checks / 5);
}

}  // namespace

TEST(PrincipledBsdf, GradientsMatchFiniteDifferences) { check_gradients(BsdfKind::PrincipledGGX, 21); }
TEST(PrincipledBsdf, MultiscatterGradientsMatchFiniteDifferences) { check_gradients(BsdfKind::PrincipledMultiGGX, 22); }
TEST(OrenNayarBsdf, GradientsMatchFiniteDifferences) { check_gradients(BsdfKind::OrenNayar, 23); }

TEST(PrincipledBsdf, NoNaNEver) {
  Rng rng(30);
  for (int i = 0; i < 200000; ++i) {
    MaterialParams p;
    p.albedo = Vec3(rng.next(), rng.next(), rng.next()) * (i % 7 == 0 ? 0.0f : 1.0f);
    p.roughness = i % 5 == 0 ? 0.0f : rng.next();
    p.metallic = i % 11 == 0 ? 1.0f : rng.next();
    p.specular = i % 13 == 0 ? 0.0f : rng.next();
    p.specular_tint = rng.next();
    Vec3 wo = random_dir(rng, i % 3 == 0 ? 0.0f : 1e-4f), wi = random_dir(rng);
    for (BsdfKind kind : {BsdfKind::PrincipledGGX, BsdfKind::PrincipledMultiGGX, BsdfKind::OrenNayar}) {
      Bsdf bsdf(kind, p, wo);
      BsdfSample s = bsdf.sample(rng.next(), rng.next(), rng.next());
      MaterialGrad g;
      Vec3 f = bsdf.eval_grad(wi, Vec3(1.0f), g);
      ASSERT_TRUE(std::isfinite(f.x + f.y + f.z + bsdf.pdf(wi)));
      ASSERT_TRUE(std::isfinite(g.d_albedo.x + g.d_albedo.y + g.d_albedo.z + g.d_roughness + g.d_metallic));
      if (s.valid) {
        ASSERT_TRUE(std::isfinite(s.weight.x + s.weight.y + s.weight.z + s.pdf));
      }
    }
  }
}
