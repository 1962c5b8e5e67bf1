// Screen-space bins for camera rays (accel/primary_bins.h) against the BVH walk:
// the same hits (t, alpha, id bits), in the same order, and the same end (stop,
// mesh) for jittered camera rays over the image and beyond it, with and without
// the opacity stop and with visitors that stop early; a Gaussian straddling the
// camera plane and a cropped camera included. Then whole renders and gradients
// are bit-identical with the bins and without, and the budget turns them off.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "ptir/accel/primary_bins.h"
#include "ptir/render/render_path.h"
#include "ptir/scene/scene_json.h"
#include "test_scenes.h"

using namespace ptir;

namespace {

Scene bins_scene() {
  Scene s;
  *s.gaussians = test::gaussian_sphere(3000, 0.5f, Vec3(0.6f, 0.5f, 0.4f), 0.45f, 0.3f);
  GaussianField extra = test::random_field(400, 11, 0.02f, 0.2f);
  for (size_t i = 0; i < extra.size(); ++i) extra.position[i] = extra.position[i] * 1.5f;
  // One large Gaussian around the camera centre: its box straddles the camera plane.
  test::add_gaussian(extra, Vec3(0.0f, -2.2f, 1.0f), Vec3(0.3f, 0.3f, 0.3f), {1, 0, 0, 0}, 0.5f);
  append_gaussians(*s.gaussians, std::move(extra));
  TriangleMesh floor = test::quad_z(-0.5f, 4.0f);
  floor.material.base_colour = Vec3(0.7f, 0.6f, 0.5f);
  s.meshes.push_back(floor);
  Affine light_xf;
  light_xf.translation = Vec3(0.6f, 0.3f, 1.5f);
  s.emitters.push_back(AreaLight::from_blender(light_xf, AreaShape::Rectangle, 0.6f, 0.6f, 60.0f, Vec3(1.0f)));
  Image map(16, 8, {"R", "G", "B"});
  for (float& v : map.pixels) v = 0.5f;
  s.environment = Environment(map, 1.0f);
  s.integrator.max_bounces = 2;
  return s;
}

Camera bins_camera(int w, int h) {
  Vec3 eye(0.0f, -2.2f, 1.0f), target(0.0f, 0.0f, -0.1f);
  Vec3 back = normalize(eye - target), right = normalize(cross(Vec3(0, 0, 1), back)), up = cross(back, right);
  float m[16] = {right.x, up.x, back.x, eye.x, right.y, up.y, back.y, eye.y, right.z, up.z, back.z, eye.z, 0, 0, 0, 1};
  return make_camera(m, 0.8f, w, h);
}

struct Walked {
  std::vector<GaussianHit> hits;
  WalkEnd end;
};

bool same_hits(const Walked& a, const Walked& b) {
  if (a.hits.size() != b.hits.size() || a.end.stopped != b.end.stopped || a.end.mesh.valid != b.end.mesh.valid)
    return false;
  if (a.end.mesh.valid && (a.end.mesh.t != b.end.mesh.t || a.end.mesh.mesh != b.end.mesh.mesh || a.end.mesh.prim != b.end.mesh.prim))
    return false;
  return a.hits.empty() || std::memcmp(a.hits.data(), b.hits.data(), a.hits.size() * sizeof(GaussianHit)) == 0;
}

}  // namespace

TEST(PrimaryBins, CameraRaysGetTheBvhWalkHitForHit) {
  Scene s = bins_scene();
  SceneAccel accel(*s.gaussians, s.meshes);
  for (const Camera& cam : {bins_camera(48, 40), bins_camera(96, 80).crop(30, 20, 40, 36)}) {
    auto bins = PrimaryBins::build(accel, cam, size_t(64) << 20);
    ASSERT_TRUE(bins);
    EXPECT_GT(bins->entries(), 3000u);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> ux(-6.0f, float(cam.width) + 6.0f), uy(-6.0f, float(cam.height) + 6.0f);
    size_t rays = 0, with_hits = 0, meshes = 0, stopped = 0;
    for (int i = 0; i < 3000; ++i) {
      Ray ray = cam.generate_ray(ux(rng), uy(rng));
      const bool opaque_stop = i % 2 == 0;
      const int stop_after = i % 3 == 0 ? int(rng() % 6) : 1 << 30;  // visitors that stop early
      Walked a, b;
      auto record = [&](Walked& w) {
        return [&w, stop_after](const GaussianHit& h) {
          w.hits.push_back(h);
          return int(w.hits.size()) < stop_after;
        };
      };
      a.end = accel.walk(ray, record(a), nullptr, opaque_stop);
      b.end = bins->walk(ray, record(b), opaque_stop);
      ASSERT_TRUE(same_hits(a, b)) << "ray " << i << ": " << a.hits.size() << " vs " << b.hits.size() << " hits";
      rays++;
      with_hits += !a.hits.empty();
      meshes += a.end.mesh.valid;
      stopped += a.end.stopped;
    }
    EXPECT_GT(with_hits, rays / 4);
    EXPECT_GT(meshes, 50u);
    EXPECT_GT(stopped, 100u);
  }
}

TEST(PrimaryBins, RendersAndGradientsAreBitIdenticalWithAndWithoutBins) {
  Scene s = bins_scene();
  PathTracer tracer(s);
  const Camera cam = bins_camera(24, 20);
  IntegratorSettings with = s.integrator, without = s.integrator;
  with.spp = without.spp = 2;
  without.primary_bins_bytes = 0;
  Image a = render_path(tracer, cam, with), b = render_path(tracer, cam, without);
  ASSERT_EQ(a.pixels, b.pixels);
  double sum = 0.0;
  for (float v : a.pixels) sum += v;
  EXPECT_GT(sum, 1.0);
  Image weights(cam.width, cam.height, {"R", "G", "B"});
  for (size_t i = 0; i < weights.pixels.size(); ++i) weights.pixels[i] = float(i % 7) - 3.0f;
  SceneGradients ga = SceneGradients::zeros_like(s), gb = ga;
  render_path_backward(tracer, cam, with, weights, ga);
  render_path_backward(tracer, cam, without, weights, gb);
  for (size_t i = 0; i < ga.gaussian_albedo.size(); ++i) {
    ASSERT_EQ(ga.gaussian_albedo[i].x, gb.gaussian_albedo[i].x) << i;
    ASSERT_EQ(ga.gaussian_roughness[i], gb.gaussian_roughness[i]) << i;
  }
  ASSERT_EQ(ga.environment, gb.environment);
}

TEST(PrimaryBins, OverBudgetGivesNoBins) {
  Scene s = bins_scene();
  SceneAccel accel(*s.gaussians, s.meshes);
  EXPECT_FALSE(PrimaryBins::build(accel, bins_camera(48, 40), 1024));
  auto bins = PrimaryBins::build(accel, bins_camera(48, 40), size_t(64) << 20);
  ASSERT_TRUE(bins);
  EXPECT_LE(bins->bytes(), size_t(64) << 20);
}
