// The equivalent surface interaction: aggregate formulas by hand, validity,
// normal rule, and the discrete pick's distribution.
#include <gtest/gtest.h>

#include "ptir/transport/interaction.h"
#include "test_scenes.h"

using namespace ptir;

namespace {

GaussianField three_gaussians() {
  GaussianField f;
  test::add_gaussian(f, Vec3(0, 0, 0), Vec3(0.1f), {1, 0, 0, 0}, 0.5f, Vec3(1, 0, 0), 0.2f, 0.0f);
  test::add_gaussian(f, Vec3(0, 0, -0.1f), Vec3(0.1f), {1, 0, 0, 0}, 0.5f, Vec3(0, 1, 0), 0.6f, 0.5f);
  test::add_gaussian(f, Vec3(0, 0, -0.2f), Vec3(0.1f), {1, 0, 0, 0}, 0.5f, Vec3(0, 0, 1), 1.0f, 1.0f);
  f.normal = {Vec3(0, 0, 1), Vec3(0, 1, 0), Vec3(0, 0, -1)};
  return f;
}

}  // namespace

TEST(Interaction, AggregateMatchesHandComputation) {
  GaussianField f = three_gaussians();
  Ray ray{Vec3(0, 0, 1), Vec3(0, 0, -1)};
  InteractionBuilder b(f, InteractionSettings{}, 0.001f, ray.d);
  GaussianHit hits[3] = {{1.0f, 0.5f, 0}, {1.1f, 0.4f, 1}, {1.2f, 0.8f, 2}};
  for (auto& h : hits) b.add(h);
  SurfaceInteraction si = b.finish(ray);
  // T: 1, 0.5, 0.3 -> weights 0.5, 0.2, 0.24; O = 0.94.
  const double w[3] = {0.5, 0.2, 0.24}, O = 0.94;
  EXPECT_NEAR(si.opacity, O, 1e-6);
  EXPECT_NEAR(si.transmittance, 0.06, 1e-6);
  EXPECT_TRUE(si.valid);
  // Depth: the hit at which O first reaches 1/2 (the first: O = 0.5), not the
  // w-weighted mean (1.092), which the hits behind drag below the surface.
  EXPECT_NEAR(si.depth, 1.0, 1e-6);
  EXPECT_GT((w[0] * 1.0 + w[1] * 1.1 + w[2] * 1.2) / O, 1.05);
  EXPECT_NEAR(si.albedo.x, w[0] / O, 1e-6);
  EXPECT_NEAR(si.albedo.y, w[1] / O, 1e-6);
  EXPECT_NEAR(si.albedo.z, w[2] / O, 1e-6);
  EXPECT_NEAR(si.roughness, (w[0] * 0.2 + w[1] * 0.6 + w[2] * 1.0) / O, 1e-6);
  EXPECT_NEAR(si.metallic, (w[1] * 0.5 + w[2] * 1.0) / O, 1e-6);
  // Normal: each hit's taken on the side of the sum so far seen from the ray (two-sided
  // splats: the third, (0, 0, -1), opposes it and counts as (0, 0, 1)), then normalise
  // (0, 0.2, 0.5 + 0.24).
  Vec3 n = normalize(Vec3(0, 0.2f, 0.74f));
  EXPECT_NEAR(si.n.y, n.y, 1e-5);
  EXPECT_NEAR(si.n.z, n.z, 1e-5);
  EXPECT_NEAR(si.p.z, 1.0 - si.depth, 1e-6);
}

TEST(Interaction, DepthIsTheMedianOrTheMeanBelowOneHalf) {
  GaussianField f = three_gaussians();
  Ray ray{Vec3(0, 0, 1), Vec3(0, 0, -1)};
  // T: 1, 0.8, 0.56 -> O: 0.2, 0.44, 0.888: the third hit reaches 1/2.
  InteractionBuilder b(f, InteractionSettings{}, 0.001f, ray.d);
  GaussianHit hits[3] = {{1.0f, 0.2f, 0}, {1.1f, 0.3f, 1}, {1.2f, 0.8f, 2}};
  for (auto& h : hits) b.add(h);
  EXPECT_NEAR(b.finish(ray).depth, 1.2, 1e-6);
  // Never reaching 1/2 (an invalid interaction): the w-weighted mean.
  InteractionBuilder thin(f, InteractionSettings{}, 0.001f, ray.d);
  thin.add({1.0f, 0.2f, 0});
  thin.add({1.1f, 0.2f, 1});
  const double w0 = 0.2, w1 = 0.8 * 0.2;
  SurfaceInteraction si = thin.finish(ray);
  EXPECT_FALSE(si.valid);
  EXPECT_NEAR(si.depth, (w0 * 1.0 + w1 * 1.1) / (w0 + w1), 1e-6);
}

TEST(Interaction, SignedNormalsFromTheFileKeepTheirSign) {
  // Normals a file gives keep their sign in the sum: the third, (0, 0, -1), subtracts
  // (0, 0.2, 0.5 - 0.24), where two-sided splats would add it.
  GaussianField f = three_gaussians();
  f.normals_from_file = true;
  Ray ray{Vec3(0, 0, 1), Vec3(0, 0, -1)};
  InteractionBuilder b(f, InteractionSettings{}, 0.001f, ray.d);
  GaussianHit hits[3] = {{1.0f, 0.5f, 0}, {1.1f, 0.4f, 1}, {1.2f, 0.8f, 2}};
  for (auto& h : hits) b.add(h);
  const Vec3 n = normalize(Vec3(0, 0.2f, 0.26f));
  const SurfaceInteraction si = b.finish(ray);
  EXPECT_NEAR(si.n.y, n.y, 1e-5);
  EXPECT_NEAR(si.n.z, n.z, 1e-5);
}

TEST(Interaction, ValidityThresholdAndNormalFlip) {
  GaussianField f = three_gaussians();
  Ray ray{Vec3(0, 0, -1), Vec3(0, 0, 1)};  // from below: the first normal faces away
  InteractionBuilder b(f, InteractionSettings{}, 0.001f, ray.d);
  b.add({1.0f, 0.45f, 0});
  SurfaceInteraction si = b.finish(ray);
  EXPECT_FALSE(si.valid);  // O = 0.45 <= 0.5
  EXPECT_LE(dot(si.n, ray.d), 0.0f);
  EXPECT_NEAR(si.n.z, -1.0f, 1e-6);
  b.add({1.1f, 0.2f, 0});  // O = 0.45 + 0.55*0.2 = 0.56
  EXPECT_TRUE(b.finish(ray).valid);
}

TEST(Interaction, DiscretePickFollowsWeights) {
  GaussianField f = three_gaussians();
  Ray ray{Vec3(0, 0, 1), Vec3(0, 0, -1)};
  InteractionSettings s;
  s.mode = InteractionMode::Discrete;
  GaussianHit hits[3] = {{1.0f, 0.5f, 0}, {1.1f, 0.4f, 1}, {1.2f, 0.8f, 2}};
  const int n = 200000;
  int count[3] = {0, 0, 0};
  for (int k = 0; k < n; ++k) {
    InteractionBuilder b(f, s, 0.001f, ray.d, uint64_t(k));
    for (auto& h : hits) b.add(h);
    SurfaceInteraction si = b.finish(ray);
    count[si.picked]++;
    // The picked Gaussian supplies depth and material on its own.
    EXPECT_EQ(si.depth, hits[si.picked].t);
  }
  const double p[3] = {0.5 / 0.94, 0.2 / 0.94, 0.24 / 0.94};
  for (int j = 0; j < 3; ++j) {
    double sigma = std::sqrt(p[j] * (1 - p[j]) / n);
    EXPECT_NEAR(double(count[j]) / n, p[j], 5 * sigma) << j;
  }
}
