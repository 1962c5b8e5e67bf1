// The regularisers' material maps (render/material_maps.h) and their adjoint
// (render/aov_backward.h): the adjoint rebuilding each pixel's interaction from the
// walks the maps kept gives the same gradients, bit for bit, as tracing every
// pixel again; and either agrees with central differences of the maps themselves.
// Gaussians in front of a mesh quad (some pixels end on the mesh), both
// interaction modes, an image whose size is not a multiple of the packet's 4 x 4.
#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <random>
#include <vector>

#include "ptir/render/aov_backward.h"
#include "ptir/render/material_maps.h"
#include "test_scenes.h"

using namespace ptir;

namespace {

Camera looking_down(Vec3 eye, float fov, int width, int height) {
  float m[16] = {1, 0, 0, eye.x, 0, 1, 0, eye.y, 0, 0, 1, eye.z, 0, 0, 0, 1};
  return make_camera(m, fov, width, height);
}

Scene test_scene() {
  Scene scene;
  *scene.gaussians = test::random_field(400, 5, 0.03f, 0.25f);
  TriangleMesh quad = test::quad_z(-1.5f, 3.0f);
  quad.material.base_colour = Vec3(0.2f, 0.5f, 0.7f);
  quad.material.roughness = 0.35f;
  scene.meshes.push_back(quad);
  return scene;
}

// The floats of a Vec3 buffer, for bitwise comparison.
std::vector<float> floats(const std::vector<Vec3>& v) {
  std::vector<float> out;
  for (const Vec3& x : v) out.insert(out.end(), {x.x, x.y, x.z});
  return out;
}

// Random adjoints of the two maps.
void random_adjoints(const Camera& cam, uint32_t seed, Image* d_albedo, Image* d_roughness) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  *d_albedo = Image(cam.width, cam.height, {"R", "G", "B"});
  *d_roughness = Image(cam.width, cam.height, {"Y"});
  for (float& v : d_albedo->pixels) v = u(rng);
  for (float& v : d_roughness->pixels) v = u(rng);
}

// sum(d_albedo * albedo map + d_roughness * roughness map).
double map_loss(const SceneAccel& accel, const Camera& cam, const AovSettings& as, const Image& da, const Image& dr) {
  Image a, r, c;
  render_material_maps(accel, cam, as, {}, &a, &r, &c);
  double s = 0.0;
  for (size_t i = 0; i < a.pixels.size(); ++i) s += double(da.pixels[i]) * a.pixels[i];
  for (size_t i = 0; i < r.pixels.size(); ++i) s += double(dr.pixels[i]) * r.pixels[i];
  return s;
}

}  // namespace

TEST(MaterialMaps, AdjointFromKeptWalksGivesTheSameFloats) {
  Scene scene = test_scene();
  SceneAccel accel(*scene.gaussians, scene.meshes);
  const Camera cam = looking_down(Vec3(0.1f, -0.05f, 3.0f), 0.9f, 23, 18);
  for (InteractionMode mode : {InteractionMode::Aggregate, InteractionMode::Discrete}) {
    AovSettings as;
    as.seed = 7;
    as.interaction.mode = mode;
    Image a, r, c, a2, r2, c2;
    MaterialMapWalks walks;
    render_material_maps(accel, cam, as, {}, &a, &r, &c, &walks);
    render_material_maps(accel, cam, as, {}, &a2, &r2, &c2);
    EXPECT_EQ(a.pixels, a2.pixels);
    EXPECT_EQ(r.pixels, r2.pixels);
    EXPECT_EQ(c.pixels, c2.pixels);
    // The scene has pixels of every kind: Gaussians, the mesh, and neither.
    int on_mesh = 0, with_hits = 0;
    for (const MaterialMapWalks::Pixel& px : walks.pixels) on_mesh += px.mesh >= 0, with_hits += px.count > 0;
    EXPECT_GT(on_mesh, 20);
    EXPECT_GT(with_hits, 100);

    Image da, dr;
    random_adjoints(cam, 3, &da, &dr);
    SceneGradients kept = SceneGradients::zeros_like(scene), traced = SceneGradients::zeros_like(scene);
    render_aov_backward(accel, cam, as, &da, &dr, kept, &walks);
    render_aov_backward(accel, cam, as, &da, &dr, traced);
    EXPECT_EQ(floats(kept.gaussian_albedo), floats(traced.gaussian_albedo));
    EXPECT_EQ(kept.gaussian_roughness, traced.gaussian_roughness);
    EXPECT_EQ(floats(kept.mesh_base_colour), floats(traced.mesh_base_colour));
    EXPECT_EQ(kept.mesh_roughness, traced.mesh_roughness);
    EXPECT_NE(kept.mesh_base_colour[0].x, 0.0f);

    // Walks kept for another image size are refused.
    const Camera other = looking_down(Vec3(0.1f, -0.05f, 3.0f), 0.9f, 22, 18);
    Image oa, orr;
    random_adjoints(other, 3, &oa, &orr);
    EXPECT_THROW(render_aov_backward(accel, other, as, &oa, &orr, kept, &walks), Error);
  }
}

TEST(MaterialMaps, AdjointMatchesCentralDifferences) {
  Scene scene = test_scene();
  GaussianField& field = *scene.gaussians;
  SceneAccel accel(field, scene.meshes);  // materials are read at render time; geometry is fixed
  const Camera cam = looking_down(Vec3(0.1f, -0.05f, 3.0f), 0.9f, 21, 19);
  AovSettings as;
  as.seed = 4;
  Image da, dr;
  random_adjoints(cam, 9, &da, &dr);
  Image a, r, c;
  MaterialMapWalks walks;
  render_material_maps(accel, cam, as, {}, &a, &r, &c, &walks);
  SceneGradients g = SceneGradients::zeros_like(scene);
  render_aov_backward(accel, cam, as, &da, &dr, g, &walks);
  // The Gaussians with the largest gradients, and the mesh.
  std::vector<size_t> ids(field.size());
  for (size_t i = 0; i < ids.size(); ++i) ids[i] = i;
  std::sort(ids.begin(), ids.end(), [&](size_t x, size_t y) {
    return std::fabs(g.gaussian_albedo[x].y) > std::fabs(g.gaussian_albedo[y].y);
  });
  const float h = 1e-2f;
  int checked = 0;
  for (int k = 0; k < 6; ++k) {
    const size_t i = ids[k];
    ASSERT_GT(std::fabs(g.gaussian_albedo[i].y), 1e-3f);
    const float a0 = field.albedo[i].y, r0 = field.roughness[i];
    field.albedo[i].y = a0 + h;
    const double lp = map_loss(accel, cam, as, da, dr);
    field.albedo[i].y = a0 - h;
    const double lm = map_loss(accel, cam, as, da, dr);
    field.albedo[i].y = a0;
    EXPECT_NEAR((lp - lm) / (2 * h), g.gaussian_albedo[i].y, 2e-3 * (1 + std::fabs(g.gaussian_albedo[i].y)));
    field.roughness[i] = r0 + h;
    const double rp = map_loss(accel, cam, as, da, dr);
    field.roughness[i] = r0 - h;
    const double rm = map_loss(accel, cam, as, da, dr);
    field.roughness[i] = r0;
    EXPECT_NEAR((rp - rm) / (2 * h), g.gaussian_roughness[i], 2e-3 * (1 + std::fabs(g.gaussian_roughness[i])));
    checked++;
  }
  EXPECT_EQ(checked, 6);
  // The mesh's base colour (red channel): pixels ending on it.
  const float b0 = scene.meshes[0].material.base_colour.x;
  scene.meshes[0].material.base_colour.x = b0 + h;
  const double mp = map_loss(accel, cam, as, da, dr);
  scene.meshes[0].material.base_colour.x = b0 - h;
  const double mm = map_loss(accel, cam, as, da, dr);
  scene.meshes[0].material.base_colour.x = b0;
  EXPECT_GT(std::fabs(g.mesh_base_colour[0].x), 1e-2f);
  EXPECT_NEAR((mp - mm) / (2 * h), g.mesh_base_colour[0].x, 2e-3 * (1 + std::fabs(g.mesh_base_colour[0].x)));
}
