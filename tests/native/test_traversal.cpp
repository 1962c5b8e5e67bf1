// Embree k-buffer traversal against a naive reference that evaluates every
// Gaussian for every ray and sorts, and mesh occlusion against an independent
// ray-triangle test.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "ptir/accel/scene_accel.h"
#include "ptir/render/aov.h"
#include "ptir/transport/interaction.h"
#include "reference_hits.h"
#include "test_scenes.h"

using namespace ptir;

namespace {

// Möller–Trumbore in double precision; returns t or -1.
double ray_triangle(const Ray& r, Vec3 a, Vec3 b, Vec3 c) {
  double e1[3] = {b.x - a.x, b.y - a.y, b.z - a.z}, e2[3] = {c.x - a.x, c.y - a.y, c.z - a.z};
  double d[3] = {r.d.x, r.d.y, r.d.z};
  double p[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
  double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
  if (std::fabs(det) < 1e-12) return -1;
  double s[3] = {r.o.x - a.x, r.o.y - a.y, r.o.z - a.z};
  double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) / det;
  if (u < 0 || u > 1) return -1;
  double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
  double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
  if (v < 0 || u + v > 1) return -1;
  return (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
}

// Closest mesh hit by brute force over every triangle.
double naive_mesh_t(const Ray& r, const std::vector<TriangleMesh>& meshes) {
  double best = r.tmax;
  for (const auto& m : meshes)
    for (const auto& tri : m.triangles) {
      double t = ray_triangle(r, m.vertices[tri[0]], m.vertices[tri[1]], m.vertices[tri[2]]);
      if (t >= r.tmin && t < best) best = t;
    }
  return best;
}

using test::naive_hits;

// The walk with a compositing visitor; with stop_when_opaque the traversal also
// prunes behind the point where the ray turns opaque.
std::vector<GaussianHit> walk_hits(const SceneAccel& accel, const Ray& r, bool stop_when_opaque = false,
                                   WalkEnd* end_out = nullptr, const HitTest* skip = nullptr) {
  std::vector<GaussianHit> hits;
  float T = 1;
  WalkEnd end = accel.walk(
      r,
      [&](const GaussianHit& h) {
        hits.push_back(h);
        T *= 1 - h.alpha;
        return T >= accel.settings().cull.min_transmittance;
      },
      nullptr, stop_when_opaque, skip);
  if (end_out) *end_out = end;
  return hits;
}

Ray random_ray(std::mt19937& rng, bool inside) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Ray r;
  // Origins outside the cube, or inside it (starting within Gaussians).
  r.o = inside ? Vec3(u(rng), u(rng), u(rng)) * 0.8f : normalize(Vec3(u(rng), u(rng), u(rng))) * 3.0f;
  Vec3 target(u(rng) * 0.7f, u(rng) * 0.7f, u(rng) * 0.7f);
  r.d = inside ? normalize(Vec3(u(rng), u(rng), u(rng))) : normalize(target - r.o);
  return r;
}

void expect_same_hits(const std::vector<GaussianHit>& a, const std::vector<GaussianHit>& b, int ray) {
  test::expect_same_hits(a, b, "ray " + std::to_string(ray));
}

}  // namespace

class TraversalVsNaive : public ::testing::TestWithParam<int> {};

TEST_P(TraversalVsNaive, IdenticalHitSets) {
  const int k = GetParam();
  GaussianField field = test::random_field(300, 11);
  std::vector<TriangleMesh> meshes;
  AccelSettings settings;
  settings.k = k;
  SceneAccel accel(field, meshes, settings);
  std::mt19937 rng(5);
  size_t total = 0;
  for (int i = 0; i < 400; ++i) {
    Ray r = random_ray(rng, i % 2 == 1);
    auto expected = naive_hits(accel.trace_data(), r, r.tmax, settings.cull);
    expect_same_hits(walk_hits(accel, r, false), expected, i);
    expect_same_hits(walk_hits(accel, r, true), expected, i);
    total += expected.size();
  }
  EXPECT_GT(total, 2000u);  // the rays really cross the field
}

INSTANTIATE_TEST_SUITE_P(KBuffer, TraversalVsNaive, ::testing::Values(1, 3, 16, 64));

TEST(Traversal, SparseFaintFieldNeedsManyRounds) {
  // Faint Gaussians: the walk rarely stops early, so every hit on the ray is visited.
  GaussianField field;
  for (int i = 0; i < 100; ++i)
    test::add_gaussian(field, Vec3(0, 0, -0.05f * i), Vec3(0.1f), {1, 0, 0, 0}, 0.05f);
  SceneAccel accel(field, {}, AccelSettings{CullSettings{}, 4});
  Ray r{Vec3(0, 0, 1), Vec3(0, 0, -1)};
  auto hits = walk_hits(accel, r);
  auto expected = naive_hits(accel.trace_data(), r, r.tmax, accel.settings().cull);
  EXPECT_EQ(hits.size(), 100u);
  expect_same_hits(hits, expected, 0);
}

TEST(Traversal, MeshOccludesGaussiansBehindNotInFront) {
  GaussianField field;
  // Gaussians on the z axis at z = 1 (in front of the wall) and z = -1 (behind it).
  test::add_gaussian(field, Vec3(0, 0, 1), Vec3(0.1f), {1, 0, 0, 0}, 0.5f);
  test::add_gaussian(field, Vec3(0, 0, -1), Vec3(0.1f), {1, 0, 0, 0}, 0.5f);
  std::vector<TriangleMesh> meshes = {test::quad_z(0.0f, 2.0f)};
  SceneAccel accel(field, meshes);
  Ray r{Vec3(0, 0, 3), Vec3(0, 0, -1)};
  std::vector<uint32_t> ids;
  WalkEnd end = accel.walk(r, [&](const GaussianHit& h) {
    ids.push_back(h.id);
    return true;
  });
  ASSERT_EQ(ids.size(), 1u);
  EXPECT_EQ(ids[0], 0u);
  ASSERT_TRUE(end.mesh.valid);
  EXPECT_NEAR(end.mesh.t, 3.0f, 1e-5f);
  // From behind the wall only the far Gaussian is seen.
  Ray back{Vec3(0, 0, -3), Vec3(0, 0, 1)};
  ids.clear();
  accel.walk(back, [&](const GaussianHit& h) {
    ids.push_back(h.id);
    return true;
  });
  ASSERT_EQ(ids.size(), 1u);
  EXPECT_EQ(ids[0], 1u);
}

TEST(Traversal, RandomFieldWithWallsMatchesNaive) {
  GaussianField field = test::random_field(300, 21);
  std::vector<TriangleMesh> meshes = {test::quad_z(0.1f, 0.6f), test::quad_z(-0.5f, 0.4f)};
  for (int k : {2, 16}) {
    AccelSettings settings;
    settings.k = k;
    SceneAccel accel(field, meshes, settings);
    std::mt19937 rng(9);
    int mesh_rays = 0;
    for (int i = 0; i < 400; ++i) {
      Ray r = random_ray(rng, i % 3 == 0);
      double t_mesh = naive_mesh_t(r, meshes);
      auto expected = naive_hits(accel.trace_data(), r, float(t_mesh), settings.cull);
      for (bool opaque_walk : {false, true}) {
        WalkEnd end;
        auto got = walk_hits(accel, r, opaque_walk, &end);
        // Skip rays grazing a mesh edge where float and double disagree on the hit.
        if (std::isfinite(t_mesh) && !end.stopped && !end.mesh.valid) continue;
        if (end.mesh.valid) {
          mesh_rays++;
          EXPECT_NEAR(end.mesh.t, t_mesh, 1e-4 * (1 + t_mesh)) << "ray " << i;
        }
        expect_same_hits(got, expected, i);
      }
    }
    EXPECT_GT(mesh_rays, 50);
  }
}

TEST(Traversal, AovsMatchNaiveComposite) {
  GaussianField field = test::random_field(400, 33, 0.05f, 0.25f);
  SceneAccel accel(field, {});
  Camera cam;
  float c2w[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 3.5f, 0, 0, 0, 1};
  cam = make_camera(c2w, 0.7f, 24, 20);
  AovSettings settings;
  Image albedo = render_aov(accel, cam, Aov::Albedo, settings);
  Image depth = render_aov(accel, cam, Aov::Depth, settings);
  Image opacity = render_aov(accel, cam, Aov::Opacity, settings);
  Image diffuse = render_aov(accel, cam, Aov::DiffuseColor, settings);  // Blender's Diffuse Color pass
  int valid = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      Ray r = cam.generate_ray(x + 0.5f, y + 0.5f);
      auto hits = naive_hits(accel.trace_data(), r, r.tmax, accel.settings().cull);
      // Composite by hand with the docs/method.md §3 formulas.
      double T = 1, O = 0, D = 0, Dmed = -1;  // Dmed: where O first reaches 1/2
      Vec3 A;
      double M = 0;
      for (const auto& h : hits) {
        double w = T * h.alpha;
        O += w;
        D += w * h.t;
        if (Dmed < 0 && float(O) >= 0.5f) Dmed = h.t;
        A += float(w) * field.albedo[h.id];
        M += w * field.metallic[h.id];
        T *= 1 - h.alpha;
      }
      EXPECT_NEAR(opacity.at(x, y, 0), O, 1e-5);
      if (O > 0.5) {
        valid++;
        EXPECT_NEAR(depth.at(x, y, 0), Dmed, 1e-4);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(albedo.at(x, y, c), A[c] / O, 1e-5);
        // The diffuse closure's weight of the blended interaction: base colour x (1 - metallic).
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(diffuse.at(x, y, c), A[c] / O * (1 - M / O), 1e-5);
      } else {
        EXPECT_EQ(depth.at(x, y, 0), 0.0f);
      }
    }
  EXPECT_GT(valid, 50);
}

TEST(Traversal, OpaqueWalkMatchesNaiveOnDenseField) {
  // Dense field with walls inside it: most rays turn opaque, some reach a wall first.
  GaussianField field = test::random_field(3000, 41, 0.03f, 0.15f);
  std::vector<TriangleMesh> meshes = {test::quad_z(0.3f, 0.5f)};
  for (int k : {2, 8, 32}) {
    AccelSettings settings;
    settings.k = k;
    SceneAccel accel(field, meshes, settings);
    std::mt19937 rng(17);
    int opaque_rays = 0, mesh_rays = 0;
    for (int i = 0; i < 300; ++i) {
      Ray r = random_ray(rng, i % 4 == 0);
      double t_mesh = naive_mesh_t(r, meshes);
      auto expected = naive_hits(accel.trace_data(), r, float(t_mesh), settings.cull);
      WalkEnd end;
      auto got = walk_hits(accel, r, true, &end);
      if (std::isfinite(t_mesh) && !end.stopped && !end.mesh.valid) continue;  // grazing a wall edge
      opaque_rays += end.stopped;
      mesh_rays += end.mesh.valid;
      expect_same_hits(got, expected, i);
    }
    EXPECT_GT(opaque_rays, 100) << "k=" << k;
    EXPECT_GT(mesh_rays, 5) << "k=" << k;
  }
}

namespace {

// A test of a hit that depends on its id and t only (as the self-hit rule and the
// stochastic shadow test do): drops / occludes about a third of the hits.
bool odd_hit(const GaussianHit& h) { return (h.id * 2654435761u >> 7) % 3 == 0 || (h.t < 0.4f && h.id % 5 == 1); }
const auto odd_hit_test = [](const GaussianHit& h) { return odd_hit(h); };
// Rarer: about one hit in twelve occludes.
bool rare_hit(const GaussianHit& h) { return (h.id * 2654435761u >> 9) % 12 == 0; }
const auto rare_hit_test = [](const GaussianHit& h) { return rare_hit(h); };

}  // namespace

TEST(Traversal, SkippedHitsLeaveTheOpaqueWalkAsIfAbsent) {
  // The walk with a skip test, stopping where the ray turns opaque, against the
  // naive hits with the skipped ones removed before the transmittance cut.
  GaussianField field = test::random_field(3000, 43, 0.03f, 0.15f);
  std::vector<TriangleMesh> meshes = {test::quad_z(0.3f, 0.5f)};
  const HitTest skip = hit_test(odd_hit_test);
  for (int k : {2, 32}) {
    AccelSettings settings;
    settings.k = k;
    SceneAccel accel(field, meshes, settings);
    CullSettings no_cut = settings.cull;
    no_cut.min_transmittance = 0.0f;
    std::mt19937 rng(19);
    int opaque_rays = 0, skipped = 0;
    for (int i = 0; i < 300; ++i) {
      Ray r = random_ray(rng, i % 4 == 0);
      double t_mesh = naive_mesh_t(r, meshes);
      std::vector<GaussianHit> expected;
      float T = 1;
      for (const GaussianHit& h : naive_hits(accel.trace_data(), r, float(t_mesh), no_cut)) {
        if (odd_hit(h)) {
          skipped++;
          continue;
        }
        expected.push_back(h);
        T *= 1 - h.alpha;
        if (T < settings.cull.min_transmittance) break;
      }
      WalkEnd end;
      std::vector<GaussianHit> got = walk_hits(accel, r, /*stop_when_opaque=*/true, &end, &skip);
      if (std::isfinite(t_mesh) && !end.stopped && !end.mesh.valid) continue;  // grazing a wall edge
      opaque_rays += end.stopped;
      expect_same_hits(got, expected, i);
    }
    EXPECT_GT(opaque_rays, 100) << "k=" << k;
    EXPECT_GT(skipped, 1000) << "k=" << k;
  }
}

TEST(Traversal, OcclusionQueryMatchesTheWalk) {
  // occluded() against walking every hit in order until one occludes, or a wall:
  // rays from outside and inside, to infinity and to a finite end.
  GaussianField field = test::random_field(600, 47, 0.02f, 0.12f);
  std::vector<TriangleMesh> meshes = {test::quad_z(0.1f, 0.6f), test::quad_z(-0.5f, 0.4f)};
  AccelSettings settings;
  SceneAccel accel(field, meshes, settings);
  const HitTest occludes = hit_test(rare_hit_test);
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int blocked = 0, open = 0, by_gaussian = 0;
  for (int i = 0; i < 2000; ++i) {
    Ray r = random_ray(rng, i % 2 == 0);
    if (i % 4 != 0) r.tmax = 0.1f + 1.5f * u(rng);
    bool hit_found = false;
    WalkEnd end = accel.walk(r, [&](const GaussianHit& h) { return !(hit_found = rare_hit(h)); });
    const bool expected = hit_found || end.mesh.valid;
    // Skip rays grazing a mesh edge where the two triangle tests could round apart.
    Ray whole = r;
    whole.tmax = INFINITY;
    const double t_mesh = naive_mesh_t(whole, meshes);
    if (std::isfinite(t_mesh) && std::abs(t_mesh - r.tmax) < 1e-3) continue;
    EXPECT_EQ(accel.occluded(r, occludes), expected) << "ray " << i;
    (expected ? blocked : open)++;
    by_gaussian += hit_found;
  }
  EXPECT_GT(blocked, 300);
  EXPECT_GT(open, 300);
  EXPECT_GT(by_gaussian, 200) << blocked << " blocked, " << open << " open";
}
