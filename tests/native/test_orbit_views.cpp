// Virtual cameras around a splat object (scene/orbit_views.h): robust bounds that
// ignore floaters and faint splats, and an orbit with every camera outside them,
// looking at the centre.
#include <gtest/gtest.h>

#include <cmath>

#include "ptir/core/error.h"
#include "ptir/scene/orbit_views.h"

namespace ptir {
namespace {

// n splats uniform on a unit sphere about `centre`, plus `floaters` opaque ones far away.
GaussianField sphere_with_floaters(int n, Vec3 centre, int floaters) {
  GaussianField f;
  for (int i = 0; i < n + floaters; ++i) {
    const float z = 1.0f - 2.0f * (float(i % n) + 0.5f) / float(n), r = std::sqrt(1.0f - z * z);
    const float phi = 2.39996323f * float(i);
    const bool far = i >= n;
    f.position.push_back(far ? centre + Vec3(50.0f + float(i), -40.0f, 30.0f) : centre + Vec3(r * std::cos(phi), r * std::sin(phi), z));
    f.scale.push_back(Vec3(0.02f, 0.02f, 0.001f));
    f.rotation.push_back({1, 0, 0, 0});
    f.opacity.push_back(0.9f);
  }
  return f;
}

TEST(OrbitViews, BoundsTrimFloatersAndFaintSplats) {
  GaussianField f = sphere_with_floaters(2000, Vec3(3, -2, 1), 5);  // 5 floaters: 0.25 % of the weight
  f.position.push_back(Vec3(500, 500, 500));
  f.scale.push_back(Vec3(0.02f));
  f.rotation.push_back({1, 0, 0, 0});
  f.opacity.push_back(0.01f);  // faint: does not count
  const SplatBounds b = robust_splat_bounds(f);
  EXPECT_EQ(b.counted, 2005u);
  EXPECT_NEAR(b.centre.x, 3.0f, 0.05f);
  EXPECT_NEAR(b.centre.y, -2.0f, 0.05f);
  EXPECT_NEAR(b.centre.z, 1.0f, 0.05f);
  // The unit sphere's radius plus 3 sigma of the largest scale (0.06), within the 1-99 % trim.
  EXPECT_GT(b.radius, 0.95f);
  EXPECT_LT(b.radius, 1.1f);
}

TEST(OrbitViews, CamerasOutsideLookingAtTheCentre) {
  const GaussianField f = sphere_with_floaters(2000, Vec3(0.5f, 0, 0), 0);
  OrbitOptions o;
  const OrbitPlan plan = plan_orbit(f, o);
  EXPECT_EQ(plan.views, 24);   // 2000 splats: the minimum count
  EXPECT_EQ(plan.size, 256);   // and the minimum size
  ASSERT_EQ(plan.cameras.size(), 24u);
  for (const Camera& c : plan.cameras) {
    const Vec3 to_centre = plan.bounds.centre - c.centre();
    EXPECT_GT(length(to_centre), 2.5f * plan.bounds.radius);
    const Vec3 forward = -c.cam_to_world.linear.col(2);  // cameras look down -z
    EXPECT_GT(dot(normalize(to_centre), forward), 0.9999f);
    const float elevation = std::asin(-forward.z) * 180.0f / 3.14159265f;
    EXPECT_GE(elevation, -30.5f);
    EXPECT_LE(elevation, 75.5f);
  }
  o.distance_scale = 0.2f;  // asked for: inside the bounds
  EXPECT_LT(plan_orbit(f, o).distance, plan.bounds.radius);
  o.elevation_min = 80;
  o.elevation_max = 10;
  EXPECT_THROW(plan_orbit(f, o), Error);
}

}  // namespace
}  // namespace ptir
