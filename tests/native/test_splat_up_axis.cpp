// The up axis of a splat PLY (scene/splat_up_axis.h) and the orbit measured about
// it (scene/orbit_views.h), on synthetic fields (the real PLYs: tests/python/test_splat_up_axis.py).
//
// The test that can fail: a field whose capture stood on -y (a trainer's frame, +z
// turned by 90 degrees about x) must get its orbit's elevations within -30..75
// degrees about -y; the same orbit about +z (the rule not applied) puts views 90
// degrees off that range, under the object.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "ptir/core/error.h"
#include "ptir/scene/orbit_views.h"
#include "ptir/scene/splat_up_axis.h"

namespace ptir {
namespace {

constexpr float kPi = 3.14159265358979f;

float angle_deg(Vec3 a, Vec3 b) {
  return std::acos(std::clamp(dot(normalize(a), normalize(b)), -1.0f, 1.0f)) * 180.0f / kPi;
}

// A field of n splats on a unit sphere whose SH (degree 3) holds what a trainer's
// fit leaves when the cameras orbited about `up` from above: a view-dependent
// colour that varies with the horizontal part of the view direction d (camera to
// splat; a random direction per splat) and a sheen seen from above (d pointing
// down), projected on the SH basis by quadrature over the sphere.
GaussianField trained_field(int n, Vec3 up) {
  GaussianField f;
  f.sh_degree = 3;
  const int nk = 16, nq = 4000;
  std::vector<Vec3> dirs;
  for (int j = 0; j < nq; ++j) {
    const float z = 1.0f - 2.0f * (float(j) + 0.5f) / float(nq), r = std::sqrt(1.0f - z * z);
    dirs.emplace_back(r * std::cos(2.39996323f * float(j)), r * std::sin(2.39996323f * float(j)), z);
  }
  Vec3 e1, e2;
  horizontal_axes(up, &e1, &e2);
  for (int i = 0; i < n; ++i) {
    const float z = 1.0f - 2.0f * (float(i) + 0.5f) / float(n), r = std::sqrt(1.0f - z * z);
    f.position.push_back(Vec3(r * std::cos(2.39996323f * float(i)), r * std::sin(2.39996323f * float(i)), z));
    f.scale.push_back(Vec3(0.05f, 0.05f, 0.005f));
    f.rotation.push_back({1, 0, 0, 0});
    f.opacity.push_back(0.9f);
    const float a = 1.7f * float(i);
    const Vec3 horizontal = std::cos(a) * e1 + std::sin(a) * e2;
    std::vector<float> sh(nk * 3, 0.0f);
    float y[kMaxShCoefficients];
    for (const Vec3& d : dirs) {
      const float below = std::max(0.0f, -dot(d, up));
      const float g = 0.2f * dot(d, horizontal) + 0.15f * below * below * below;
      sh_basis(3, d, y);
      for (int k = 1; k < nk; ++k)
        for (int c = 0; c < 3; ++c) sh[k * 3 + c] += 4.0f * kPi / float(nq) * y[k] * g * (0.6f + 0.2f * float(c));
    }
    f.sh.insert(f.sh.end(), sh.begin(), sh.end());
  }
  return f;
}

// Elevations in degrees of the plan's cameras about `up`, seen from the bounds' centre.
std::vector<float> elevations(const OrbitPlan& plan, Vec3 up) {
  std::vector<float> e;
  for (const Camera& c : plan.cameras)
    e.push_back(90.0f - angle_deg(c.centre() - plan.bounds.centre, up));
  return e;
}

TEST(SplatUpAxis, ParsesAxesAndVectors) {
  EXPECT_EQ(parse_up_axis("x").x, 1.0f);
  EXPECT_EQ(parse_up_axis("-y").y, -1.0f);
  EXPECT_EQ(parse_up_axis("Z").z, 1.0f);
  const Vec3 v = parse_up_axis("0, 3, 4");
  EXPECT_NEAR(v.y, 0.6f, 1e-6f);
  EXPECT_NEAR(v.z, 0.8f, 1e-6f);
  for (const char* bad : {"up", "0,0,0", "1,2", "1,2,3,4", "nan,0,1", ""})
    EXPECT_THROW(parse_up_axis(bad), Error) << bad;
}

TEST(SplatUpAxis, CamerasGiveTheirMeanUp) {
  const Vec3 up = normalize(Vec3(0.3f, -0.95f, 0.1f));
  Vec3 e1, e2;
  horizontal_axes(up, &e1, &e2);
  std::vector<Camera> cams;
  for (int k = 0; k < 12; ++k) {
    const float el = (10.0f + 4.0f * float(k)) * kPi / 180.0f, az = 0.5f * float(k);
    const Vec3 eye = 3.0f * (std::cos(el) * (std::cos(az) * e1 + std::sin(az) * e2) + std::sin(el) * up);
    const Affine a = look_at(eye, Vec3(0, 0, 0), up);
    Camera c;
    c.cam_to_world = a;
    cams.push_back(c);
  }
  const UpCue cue = up_from_cameras(cams);
  ASSERT_TRUE(cue.clear);
  // The cameras look down at the object, so their mean up leans away from it: within their elevations.
  EXPECT_LT(angle_deg(cue.up, up), 15.0f);
  const UpAxis decided = decide_up_axis(GaussianField{}, "", cams);
  EXPECT_EQ(decided.source, "cameras");
  // Half of them upside down: no agreement, no answer.
  for (size_t k = 0; k < cams.size(); k += 2) cams[k].cam_to_world.linear = cams[k].cam_to_world.linear * Mat3::from_rows({-1, 0, 0}, {0, -1, 0}, {0, 0, 1});
  EXPECT_FALSE(up_from_cameras(cams).clear);
}

TEST(SplatUpAxis, ShCueFollowsTheCapturesUp) {
  for (const Vec3 up : {Vec3(0, 0, 1), Vec3(0, -1, 0), normalize(Vec3(0.34f, -0.94f, 0.0f)), Vec3(1, 0, 0)}) {
    const UpCue cue = up_from_sh(trained_field(300, up));
    ASSERT_TRUE(cue.available);
    EXPECT_TRUE(cue.clear) << cue.note;
    EXPECT_LT(angle_deg(cue.up, up), 3.0f) << up.x << " " << up.y << " " << up.z;
  }
}

TEST(SplatUpAxis, FileConventionWhereTheDataSaysNothing) {
  GaussianField trainer = trained_field(50, Vec3(0, 0, 1));
  trainer.sh_degree = 0;  // DC only: no view-dependent radiance to read
  trainer.sh.assign(trainer.size() * 3, 0.0f);
  const UpAxis t = decide_up_axis(trainer, "", {});
  EXPECT_EQ(t.source, "trainer convention");
  EXPECT_EQ(t.up.y, -1.0f);
  GaussianField own = trainer;  // PTIR's material properties: Blender's frame
  io::PlyElement vertex;
  vertex.name = "vertex";
  io::PlyProperty albedo;
  albedo.name = "albedo_0";
  vertex.properties.push_back(albedo);
  own.source.elements.push_back(vertex);
  const UpAxis o = decide_up_axis(own, "", {});
  EXPECT_EQ(o.source, "ptir file");
  EXPECT_EQ(o.up.z, 1.0f);
  EXPECT_EQ(decide_up_axis(own, "-x", {}).up.x, -1.0f);  // the flag wins
}

TEST(SplatUpAxis, OrbitElevationsAboutTheDecidedUp) {
  const Vec3 true_up(0, -1, 0);  // +z turned by 90 degrees about x
  const GaussianField f = trained_field(300, true_up);
  const UpAxis up = decide_up_axis(f, "", {});
  ASSERT_EQ(up.source, "sh");
  OrbitOptions o;
  o.views = 40;
  o.up = up.up;
  const OrbitPlan right = plan_orbit(f, o);
  for (float e : elevations(right, true_up)) {
    EXPECT_GE(e, -30.0f - 3.0f);
    EXPECT_LE(e, 75.0f + 3.0f);
  }
  // The rule not applied: the orbit about +z sees the object from 90 degrees off its range.
  OrbitOptions z = o;
  z.up = Vec3(0, 0, 1);
  const std::vector<float> wrong = elevations(plan_orbit(f, z), true_up);
  EXPECT_LT(*std::min_element(wrong.begin(), wrong.end()), -60.0f);
  // +z itself still plans the old orbit, camera for camera.
  GaussianField g = f;
  OrbitOptions old;
  old.views = 40;
  const OrbitPlan a = plan_orbit(g, old), b = plan_orbit(g, z);
  for (size_t k = 0; k < a.cameras.size(); ++k)
    EXPECT_EQ(length(a.cameras[k].centre() - b.cameras[k].centre()), 0.0f);
}

}  // namespace
}  // namespace ptir
