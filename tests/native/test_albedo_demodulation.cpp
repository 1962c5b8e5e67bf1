// The albedo's start from the radiance (optim/albedo_demodulation.h) against closed forms:
// a splat under a constant environment (E / pi = L), the same under a black square above it
// (E / pi = L (1 - F), F the view factor of a parallel square from a point under its centre),
// and the path tracer's self-intersection rule (back-facing splats within the range skipped).
#include <gtest/gtest.h>

#include <cmath>

#include "ptir/lights/env_constant.h"
#include "ptir/optim/albedo_demodulation.h"
#include "test_scenes.h"

using namespace ptir;
using ptir::test::add_gaussian;
using ptir::test::quad_z;

namespace {

constexpr float kPi = 3.14159265358979f;

// One flat splat at the origin facing +z (0.1 wide: the self range is 0.8).
GaussianField receiver() {
  GaussianField f;
  add_gaussian(f, Vec3(0.0f), Vec3(0.1f, 0.1f, 0.001f), {1, 0, 0, 0}, 0.9f);
  return f;
}

// View factor of a square of half-side a at height h, from a point under its centre facing it.
double square_view_factor(double a, double h) {
  const double A = a / h, B = a / h;
  return 2.0 / kPi * (A / std::sqrt(1 + A * A) * std::atan(B / std::sqrt(1 + A * A)) +
                      B / std::sqrt(1 + B * B) * std::atan(A / std::sqrt(1 + B * B)));
}

}  // namespace

TEST(AlbedoDemodulation, UnderAConstantSkyTheAlbedoIsRadianceOverSky) {
  const GaussianField f = receiver();
  const SceneAccel accel(f, {});
  const SceneEnvironment sky(ConstantEnvironment(Vec3(0.5f, 0.25f, 1.0f)));
  const std::vector<Vec3> a = demodulated_albedo(accel, {Vec3(0.2f, 0.1f, 0.3f)}, sky);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_NEAR(a[0].x, 0.4f, 1e-4f);
  EXPECT_NEAR(a[0].y, 0.4f, 1e-4f);
  EXPECT_NEAR(a[0].z, 0.3f, 1e-4f);
}

TEST(AlbedoDemodulation, ABlackSquareAboveTakesItsViewFactorOffTheIrradiance) {
  const GaussianField f = receiver();
  const SceneAccel accel(f, {quad_z(1.0f, 1.0f)});
  const SceneEnvironment sky(ConstantEnvironment(Vec3(0.5f, 0.25f, 1.0f)));
  DemodulationSettings s;
  s.rays = 16384;
  const double F = square_view_factor(1.0, 1.0);  // 0.554
  const std::vector<Vec3> a = demodulated_albedo(accel, {Vec3(0.1f, 0.05f, 0.2f)}, sky, s);
  const double expected = 0.2 / (1.0 - F);  // c / (L (1 - F)) per channel
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[0][c], expected, 0.03 * expected) << c;
}

TEST(AlbedoDemodulation, BackFacingSplatsWithinTheSelfRangeAreSkippedBeyondItTheyOcclude) {
  const SceneEnvironment sky(ConstantEnvironment(Vec3(0.5f)));
  const std::vector<Vec3> radiance = {Vec3(0.1f), Vec3(0.0f)};
  DemodulationSettings s;
  s.rays = 4096;
  // A wide black opaque sheet above, facing up like the receiver: the ray from the receiver meets
  // its back. At z = 0.05 it lies within the receiver's self range (8 x 0.1) for all but the
  // grazing rays (cos < 0.0625: 0.4 % of the cosine-weighted hemisphere): the surface the ray
  // leaves, skipped; at z = 2 it occludes, as the path tracer's rays see it.
  for (float z : {0.05f, 2.0f}) {
    GaussianField f = receiver();
    add_gaussian(f, Vec3(0.0f, 0.0f, z), Vec3(3.0f, 3.0f, 0.001f), {1, 0, 0, 0}, 0.99f);
    const SceneAccel accel(f, {});
    const std::vector<Vec3> a = demodulated_albedo(accel, radiance, sky, s);
    if (z < 1.0f) {
      EXPECT_NEAR(a[0].x, 0.2f, 0.003f) << "skipped: the sky alone";
    } else {
      EXPECT_GT(a[0].x, 0.2f * 1.5f) << "occluded: less irradiance, a brighter albedo";
    }
  }
}
