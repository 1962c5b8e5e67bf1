// Blender 4.3+'s Diffuse BSDF node under v2 (material/oren_nayar_eon.h): the model
// choice, Lambert at roughness 0, a white furnace (the energy-preserving lobe with a
// white base reflects everything, where v1's Oren-Nayar loses energy), equality with
// Principled v2's own Diffuse Roughness path (principled_v2.cpp, a separate
// implementation of the same closure: Specular IOR Level 0, metallic 0), sampling
// against the pdf, and the dual-number gradients against central differences.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "bsdf_test_directions.h"
#include "chi2_test.h"
#include "ptir/material/bsdf.h"
#include "ptir/math/rng.h"

using namespace ptir;
using ptir::test::dir_at;
using ptir::test::random_dir;

namespace {

MaterialParams diffuse_node(Vec3 colour, float roughness) {
  MaterialParams p;
  p.albedo = colour;
  p.roughness = roughness;
  return p;
}

double albedo_of(BsdfKind kind, const MaterialParams& p, Vec3 wo) {
  Bsdf bsdf(kind, p, wo);
  return ptir::test::integrate_hemisphere([&](Vec3 wi) { return bsdf.eval(wi).x; });
}

}  // namespace

TEST(OrenNayarEon, DiffuseNodeModelByBlenderVersion) {
  EXPECT_EQ(resolve_bsdf(BsdfModel::PrincipledV2, SurfaceShader::Diffuse), BsdfKind::OrenNayarEon);
  EXPECT_EQ(resolve_bsdf(BsdfModel::PrincipledV1, SurfaceShader::Diffuse), BsdfKind::OrenNayar);
}

TEST(OrenNayarEon, LambertAtZeroRoughness) {
  const Vec3 wo = dir_at(40.0f), wi = normalize(Vec3(0.3f, -0.2f, 0.8f));
  const Vec3 f = Bsdf(BsdfKind::OrenNayarEon, diffuse_node(Vec3(0.8f, 0.4f, 0.2f), 0.0f), wo).eval(wi);
  EXPECT_NEAR(f.x, 0.8f * wi.z / kPi, 1e-7f);
  EXPECT_NEAR(f.z, 0.2f * wi.z / kPi, 1e-7f);
}

// White base: Cycles' multiscatter term restores what the single-scatter lobe loses
// (1 within the quadrature's accuracy); v1's Oren-Nayar at the same sigma loses
// several per cent at grazing angles -- the difference Blender 4.3 made visible.
TEST(OrenNayarEon, WhiteFurnaceAndV1Loses) {
  for (float sigma : {0.3f, 0.7f, 1.0f})
    for (float theta : {0.0f, 45.0f, 80.0f}) {
      const MaterialParams p = diffuse_node(Vec3(1.0f), sigma);
      EXPECT_NEAR(albedo_of(BsdfKind::OrenNayarEon, p, dir_at(theta)), 1.0, 2e-3) << sigma << " " << theta;
    }
  EXPECT_LT(albedo_of(BsdfKind::OrenNayar, diffuse_node(Vec3(1.0f), 1.0f), dir_at(80.0f)), 0.97);
}

TEST(OrenNayarEon, EqualsPrincipledV2DiffuseRoughness) {
  Rng rng(7);
  for (int i = 0; i < 500; ++i) {
    const Vec3 base(rng.next() * 1.2f, rng.next(), rng.next());
    const float sigma = 0.01f + 0.99f * rng.next();
    MaterialParams v2 = diffuse_node(base, 0.5f);
    v2.specular_ior_level = 0.0f;  // no specular layer: the diffuse base alone
    v2.diffuse_roughness = sigma;
    const Vec3 wo = random_dir(rng, 0.02f), wi = random_dir(rng, 0.02f);
    const Vec3 a = Bsdf(BsdfKind::OrenNayarEon, diffuse_node(base, sigma), wo).eval(wi);
    const Vec3 b = Bsdf(BsdfKind::PrincipledV2GGX, v2, wo).eval(wi);
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(a[c], b[c], 2e-6f + 2e-5f * std::fabs(b[c])) << i << " " << c;
  }
}

// The sampled estimator of the albedo (weight = f~ / pdf) against quadrature.
TEST(OrenNayarEon, SampleIsUnbiased) {
  Rng rng(11);
  for (float sigma : {0.4f, 1.0f}) {
    const MaterialParams p = diffuse_node(Vec3(0.7f, 0.5f, 0.3f), sigma);
    const Vec3 wo = dir_at(60.0f);
    Bsdf bsdf(BsdfKind::OrenNayarEon, p, wo);
    const int n = 200000;
    double sum = 0, sum2 = 0;
    for (int k = 0; k < n; ++k) {
      const BsdfSample s = bsdf.sample(rng.next(), rng.next(), rng.next());
      const double w = s.valid ? s.weight.x : 0.0;
      if (s.valid) {
        ASSERT_NEAR(s.pdf, bsdf.pdf(s.wi), 1e-5f);
      }
      sum += w;
      sum2 += w * w;
    }
    const double mean = sum / n, se = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
    EXPECT_NEAR(mean, albedo_of(BsdfKind::OrenNayarEon, p, wo), 4 * se + 1e-4) << sigma;
  }
}

TEST(OrenNayarEon, GradientsMatchFiniteDifferences) {
  Rng rng(13);
  for (int i = 0; i < 400; ++i) {
    const MaterialParams p = diffuse_node(Vec3(0.05f + 0.9f * rng.next(), 0.05f + 0.9f * rng.next(), 0.05f + 0.9f * rng.next()),
                                          0.05f + 0.9f * rng.next());
    const Vec3 wo = random_dir(rng, 0.05f), wi = random_dir(rng, 0.05f);
    const Vec3 adj(2 * rng.next() - 1, 2 * rng.next() - 1, 2 * rng.next() - 1);
    MaterialGrad g;
    const Vec3 f = Bsdf(BsdfKind::OrenNayarEon, p, wo).eval_grad(wi, adj, g);
    const Vec3 plain = Bsdf(BsdfKind::OrenNayarEon, p, wo).eval(wi);
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(f[c], plain[c], 1e-6f * std::fabs(plain[c]) + 1e-12f);
    auto value = [&](const MaterialParams& q) {
      const Vec3 v = Bsdf(BsdfKind::OrenNayarEon, q, wo).eval(wi);
      return double(adj.x) * v.x + double(adj.y) * v.y + double(adj.z) * v.z;
    };
    auto central = [&](auto set, float x) {
      const float h = 1e-3f;
      MaterialParams a = p, b = p;
      set(a, x + h), set(b, x - h);
      return (value(a) - value(b)) / (2.0 * h);
    };
    const double mag = std::fabs(adj.x * f.x) + std::fabs(adj.y * f.y) + std::fabs(adj.z * f.z);
    const double tol_abs = 64 * std::numeric_limits<float>::epsilon() * mag / 1e-3;
    for (int c = 0; c < 3; ++c) {
      const double d = central([c](MaterialParams& q, float v) { q.albedo[c] = v; }, p.albedo[c]);
      EXPECT_NEAR(g.d_albedo[c], d, 2e-3 * std::fabs(d) + tol_abs) << "albedo " << c << " case " << i;
    }
    const double d = central([](MaterialParams& q, float v) { q.roughness = v; }, p.roughness);
    EXPECT_NEAR(g.d_roughness, d, 2e-3 * std::fabs(d) + tol_abs) << "sigma case " << i;
    if (::testing::Test::HasFailure()) break;
  }
}
