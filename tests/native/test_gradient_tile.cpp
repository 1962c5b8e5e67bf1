// The tiled gradient reduction (transport/gradient_tile.h, render/tile_reduce.h):
// a tile's sparse buffer adds exactly what a dense buffer fed the same adds in
// the same order holds (Gaussians through hash-table growth, meshes, the
// environment dense or logged), and a whole replay gives the same floats on 1, 2
// and 3 threads and the per-pixel sum of single-pixel replays (independent of
// any tiling) to float rounding; batched camera rays (packets) change no float.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <random>

#include "ptir/math/path_sampler.h"
#include "ptir/math/pixel_filter.h"
#include "ptir/render/render_path.h"
#include "ptir/render/tile_reduce.h"
#include "ptir/transport/gradient_tile.h"
#include "test_scenes.h"

using namespace ptir;

namespace {

Scene tile_scene(int env_width, int env_height) {
  Scene s;
  *s.gaussians = test::gaussian_sphere(2000, 0.5f, Vec3(0.6f, 0.5f, 0.4f), 0.45f, 0.3f);
  TriangleMesh floor = test::quad_z(-0.5f, 4.0f);
  floor.material.base_colour = Vec3(0.7f, 0.6f, 0.5f);
  s.meshes.push_back(floor);
  Image map(env_width, env_height, {"R", "G", "B"});
  for (int y = 0; y < env_height; ++y)
    for (int x = 0; x < env_width; ++x)
      for (int c = 0; c < 3; ++c) map.at(x, y, c) = 0.2f + 0.6f * float((x + 3 * y + c) % 7) / 7.0f;
  s.environment = Environment(map, 1.0f);
  s.integrator.max_bounces = 2;
  s.integrator.russian_roulette = false;  // path replay's requirement
  return s;
}

Camera tile_camera(int w, int h) {
  Vec3 eye(0.0f, -2.2f, 1.0f), target(0.0f, 0.0f, -0.1f);
  Vec3 back = normalize(eye - target), right = normalize(cross(Vec3(0, 0, 1), back)), up = cross(back, right);
  float m[16] = {right.x, up.x, back.x, eye.x, right.y, up.y, back.y, eye.y, right.z, up.z, back.z, eye.z, 0, 0, 0, 1};
  return make_camera(m, 0.8f, w, h);
}

void expect_same_floats(const SceneGradients& a, const SceneGradients& b) {
  ASSERT_EQ(a.gaussian_albedo.size(), b.gaussian_albedo.size());
  for (size_t i = 0; i < a.gaussian_albedo.size(); ++i) {
    for (int c = 0; c < 3; ++c) ASSERT_EQ(a.gaussian_albedo[i][c], b.gaussian_albedo[i][c]) << i;
    ASSERT_EQ(a.gaussian_roughness[i], b.gaussian_roughness[i]) << i;
    ASSERT_EQ(a.gaussian_metallic[i], b.gaussian_metallic[i]) << i;
  }
  for (size_t m = 0; m < a.mesh_base_colour.size(); ++m) ASSERT_EQ(a.mesh_base_colour[m].y, b.mesh_base_colour[m].y);
  ASSERT_EQ(a.environment, b.environment);
}

}  // namespace

TEST(GradientTile, SparseSumsEqualDenseSumsInTheSameOrder) {
  for (int env_width : {8, 160}) {  // 8x4: dense environment buffer; 160x80 (38400 floats): logged adjoint calls
    Scene s = tile_scene(env_width, env_width / 2);
    SceneGradients base = SceneGradients::zeros_like(s);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (float& v : base.environment) v = u(rng);  // the tile adds onto what is there
    const bool logged = env_width != 8;
    SceneGradients dense = base, tiled = base;
    // Dense environment: the tile sums its own buffer, added once; logged: the
    // calls are replayed onto the gradients themselves, in order.
    std::vector<float> env_tile(base.environment.size(), 0.0f);
    float* env_target = logged ? dense.environment.data() : env_tile.data();
    GradientTile tile(base, s.environment);
    // 5000 adds over 1500 ids: duplicates, and the hash table grows past its initial 1024 slots.
    std::vector<Vec3> alb(s.gaussians->size(), Vec3(0.0f));
    std::vector<float> rough(s.gaussians->size(), 0.0f), metal(s.gaussians->size(), 0.0f);
    Vec3 mesh_sum(0.0f);
    float mesh_r = 0.0f;
    for (int k = 0; k < 5000; ++k) {
      uint32_t id = uint32_t(rng() % 1500u) * 7u % uint32_t(s.gaussians->size());
      Vec3 a(u(rng), u(rng), u(rng));
      float r = u(rng), m = u(rng);
      tile.add_gaussian(id, a, r, m);
      alb[id] += a, rough[id] += r, metal[id] += m;
      if (k % 97 == 0) {
        tile.add_mesh(0, a, r, m);
        mesh_sum += a;
        mesh_r += r;
      }
      if (k % 3 == 0) {
        Vec3 d = normalize(Vec3(u(rng), u(rng), u(rng) + 0.01f));
        tile.add_environment(d, a);
        s.environment->adjoint(d, a, env_target);
      }
    }
    EXPECT_GT(tile.gaussian_entries(), 1000u);
    EXPECT_LE(tile.gaussian_entries(), 1500u);
    tile.finish();
    tile.add_to(tiled);
    for (size_t i = 0; i < alb.size(); ++i) {
      dense.gaussian_albedo[i] += alb[i];
      dense.gaussian_roughness[i] += rough[i];
      dense.gaussian_metallic[i] += metal[i];
    }
    dense.mesh_base_colour[0] += mesh_sum;
    dense.mesh_roughness[0] += mesh_r;
    if (!logged)
      for (size_t i = 0; i < env_tile.size(); ++i) dense.environment[i] += env_tile[i];
    expect_same_floats(tiled, dense);
    EXPECT_EQ(tiled.mesh_roughness[0], dense.mesh_roughness[0]);
    // A cleared tile adds nothing.
    tile.clear();
    tile.finish();
    SceneGradients before = tiled;
    tile.add_to(tiled);
    expect_same_floats(tiled, before);
  }
}

TEST(GradientTile, ReplayIsTheSameOnAnyThreadCountAndEqualsPerPixelReplays) {
  Scene s = tile_scene(16, 8);
  PathTracer tracer(s);
  const Camera cam = tile_camera(42, 24);  // 11 x 6 tiles, partial ones at the right
  IntegratorSettings is = s.integrator;
  is.spp = 2;
  Image weights(cam.width, cam.height, {"R", "G", "B"});
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (float& v : weights.pixels) v = u(rng);

  std::vector<SceneGradients> by_threads;
  for (int t : {1, 2, 3}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(t));
    SceneGradients g = SceneGradients::zeros_like(s);
    TileReduceStats st;
    render_path_backward(tracer, cam, is, weights, g, {}, nullptr, &st);
    EXPECT_EQ(st.tiles, 66u);  // 4 x 4 tiles: 16 and 8 would give fewer than 64
    EXPECT_GT(st.entries, 0u);
    by_threads.push_back(std::move(g));
  }
  expect_same_floats(by_threads[0], by_threads[1]);
  expect_same_floats(by_threads[0], by_threads[2]);

  // Reference: every pixel replayed alone, summed in double (no tiling involved in the order).
  std::vector<double> ref_alb(s.gaussians->size(), 0.0), ref_env(by_threads[0].environment.size(), 0.0);
  double ref_mesh = 0.0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      Image one(cam.width, cam.height, {"R", "G", "B"});
      for (int c = 0; c < 3; ++c) one.at(x, y, c) = weights.at(x, y, c);
      SceneGradients g = SceneGradients::zeros_like(s);
      render_path_backward(tracer, cam, is, one, g);
      for (size_t i = 0; i < ref_alb.size(); ++i) ref_alb[i] += g.gaussian_albedo[i].x;
      for (size_t i = 0; i < ref_env.size(); ++i) ref_env[i] += g.environment[i];
      ref_mesh += g.mesh_base_colour[0].x;
    }
  double scale = 0.0, touched = 0.0;
  for (double v : ref_alb) scale = std::max(scale, std::fabs(v)), touched += v != 0.0;
  EXPECT_GT(touched, 100.0);
  for (size_t i = 0; i < ref_alb.size(); ++i) ASSERT_NEAR(by_threads[0].gaussian_albedo[i].x, ref_alb[i], 1e-5 * scale) << i;
  double env_scale = 0.0;
  for (double v : ref_env) env_scale = std::max(env_scale, std::fabs(v));
  EXPECT_GT(env_scale, 0.0);
  for (size_t i = 0; i < ref_env.size(); ++i) ASSERT_NEAR(by_threads[0].environment[i], ref_env[i], 1e-5 * env_scale) << i;
  EXPECT_NEAR(by_threads[0].mesh_base_colour[0].x, ref_mesh, 1e-5 * std::fabs(ref_mesh) + 1e-12);
}

// tile_scene(16, 8) with a rectangular area light above it (shadow rays to record).
static Scene lit_tile_scene() {
  Scene s = tile_scene(16, 8);
  Affine light_xf;
  light_xf.translation = Vec3(0.6f, 0.3f, 1.5f);
  s.emitters.push_back(AreaLight::from_blender(light_xf, AreaShape::Rectangle, 0.6f, 0.6f, 60.0f, Vec3(1.0f)));
  return s;
}

// A replay set-up on a scene: its tracer, a 20 x 16 view at 3 spp, and an image
// adjoint of mixed signs.
struct ReplaySetup {
  Scene s;
  PathTracer tracer;  // holds a reference to s (declared first)
  Camera cam = tile_camera(20, 16);
  IntegratorSettings is;
  Image weights;
  ReplayCache record;  // the primal's radiance and ray outcomes, when a test keeps them
  std::vector<Vec3>& radiance = record.radiance;
  std::vector<uint64_t>& shadows = record.shadows;
  explicit ReplaySetup(Scene scene) : s(std::move(scene)), tracer(s), is(s.integrator) {
    is.spp = 3;
    weights = Image(cam.width, cam.height, {"R", "G", "B"});
    for (size_t i = 0; i < weights.pixels.size(); ++i) weights.pixels[i] = float(i % 5) - 2.0f;
  }
  // The record's parts named (radiance, ray outcomes) and a walk store, as one cache.
  ReplayCache parts(bool with_radiance, bool with_shadows, WalkStore* walks = nullptr) const {
    ReplayCache c;
    if (with_radiance) c.radiance = record.radiance;
    if (with_shadows) c.shadows = record.shadows;
    c.walks = walks;
    return c;
  }
};

TEST(GradientTile, ReplayWithRecordedShadowRaysGivesTheSameFloats) {
  // The primal pass records every sample's shadow-ray outcomes; a replay that reads
  // them instead of tracing makes the same decisions, so the gradients are equal
  // bit for bit (with and without the stored radiance).
  ReplaySetup r(lit_tile_scene());
  render_path(r.tracer, r.cam, r.is, {}, nullptr, &r.record);
  size_t recorded = 0, visible = 0;
  for (uint64_t b : r.shadows) recorded += b != 0, visible += size_t(__builtin_popcountll(b));
  EXPECT_GT(recorded, r.shadows.size() / 4);
  EXPECT_GT(visible, r.shadows.size() / 2);
  SceneGradients traced = SceneGradients::zeros_like(r.s), read = traced, read_only = traced;
  const ReplayCache radiance = r.parts(true, false), shadows_only = r.parts(false, true);
  render_path_backward(r.tracer, r.cam, r.is, r.weights, traced, {}, &radiance);
  render_path_backward(r.tracer, r.cam, r.is, r.weights, read, {}, &r.record);
  render_path_backward(r.tracer, r.cam, r.is, r.weights, read_only, {}, &shadows_only);
  expect_same_floats(traced, read);
  expect_same_floats(traced, read_only);
  double sum = 0.0;
  for (const Vec3& a : traced.gaussian_albedo) sum += std::fabs(a.x);
  EXPECT_GT(sum, 0.0);
  // Wrong-sized records are refused.
  ReplayCache short_record = r.parts(true, false);
  short_record.shadows.resize(3);
  EXPECT_THROW(render_path_backward(r.tracer, r.cam, r.is, r.weights, read, {}, &short_record), Error);
  // So is Russian roulette (its survival probability depends on the materials).
  IntegratorSettings roulette = r.is;
  roulette.russian_roulette = true;
  EXPECT_THROW(render_path_backward(r.tracer, r.cam, roulette, r.weights, read), Error);
}

TEST(GradientTile, BatchedSamplesGiveTheSameFloatsAsSingleSamples) {
  // sample_radiance_batch / sample_adjoint_batch trace the camera rays of a batch
  // as packets; every sample must come out exactly as from the one-sample calls:
  // radiance, coverage, shadow-ray record, and the gradients (aggregate and
  // discrete interactions; batches of 16 + 1 and 16 + 3 samples).
  Scene s = lit_tile_scene();
  PathTracer tracer(s);
  const Camera cam = tile_camera(12, 10);
  for (InteractionMode mode : {InteractionMode::Aggregate, InteractionMode::Discrete})
    for (int n : {17, 19}) {
      IntegratorSettings is = s.integrator;
      is.interaction.mode = mode;
      is.seed = 11;
      GradientTile single(SceneGradients::zeros_like(s), s.environment), batched = single, batched_bits = single;
      size_t covered = 0, vertices = 0;
      for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x) {
          const size_t m = static_cast<size_t>(n);
          std::vector<Ray> rays(m);
          std::vector<uint64_t> pixels(m, cam.full_pixel_index(x, y)), bits(m), bits1(m);
          std::vector<uint32_t> samples(m);
          std::vector<Vec3> L(m);
          std::vector<float> c(m);
          for (int j = 0; j < n; ++j) {  // jittered rays inside the pixel
            samples[j] = uint32_t(j);
            rays[j] = cam.generate_ray(x + 0.5f + 0.45f * std::sin(1.7f * j), y + 0.5f + 0.45f * std::cos(2.3f * j));
          }
          PathStats st;
          tracer.sample_radiance_batch(rays.data(), n, pixels.data(), samples.data(), is, L.data(), c.data(), &st,
                                       bits.data());
          vertices += st.vertices;
          std::vector<PathAdjoint> adj(m), adj_bits(m);
          for (int j = 0; j < n; ++j) {
            float c1 = -1.0f;
            const Vec3 L1 = tracer.sample_radiance(rays[j], pixels[j], samples[j], is, &c1, nullptr, &bits1[j]);
            ASSERT_EQ(L1.x, L[j].x);
            ASSERT_EQ(L1.y, L[j].y);
            ASSERT_EQ(L1.z, L[j].z);
            ASSERT_EQ(c1, c[j]);
            ASSERT_EQ(bits1[j], bits[j]);
            covered += c1 > 0.0f;
            const Vec3 dL(0.3f + 0.01f * j, -0.2f, 0.1f * float(x - y));
            tracer.sample_adjoint(rays[j], pixels[j], samples[j], is, PathAdjoint{L1, dL, &single});
            adj[j] = PathAdjoint{L1, dL, &batched};
            adj_bits[j] = PathAdjoint{L1, dL, &batched_bits, &bits[j]};
          }
          tracer.sample_adjoint_batch(rays.data(), n, pixels.data(), samples.data(), is, adj.data());
          tracer.sample_adjoint_batch(rays.data(), n, pixels.data(), samples.data(), is, adj_bits.data());
        }
      EXPECT_GT(covered, size_t(cam.width * cam.height * n) / 4);
      EXPECT_GT(vertices, size_t(cam.width * cam.height * n));
      SceneGradients a = SceneGradients::zeros_like(s), b = a, c = a;
      for (auto [tile, g] : {std::pair<GradientTile*, SceneGradients*>{&single, &a}, {&batched, &b}, {&batched_bits, &c}}) {
        tile->finish();
        tile->add_to(*g);
      }
      double sum = 0.0;
      for (const Vec3& v : a.gaussian_albedo) sum += std::fabs(v.x);
      EXPECT_GT(sum, 0.0);
      expect_same_floats(a, b);
      expect_same_floats(a, c);
    }
}

TEST(GradientTile, RenderPathEqualsItsSamplesOneByOne) {
  // render_path traces the samples of neighbouring pixels in batches (5 pixels of
  // 3 samples; 16 + 4 samples of one pixel): each pixel must be the mean of its
  // samples traced one by one, the same floats; and the replay's gradients (whose
  // batches span pixels) those of replaying the samples one by one in pixel order.
  Scene s = tile_scene(16, 8);
  PathTracer tracer(s);
  const Camera cam = tile_camera(13, 7);
  const PixelFilterSampler filter(s.integrator.filter);
  for (int spp : {3, 20}) {
    IntegratorSettings is = s.integrator;
    is.spp = spp;
    ReplayCache record;
    const Image img = render_path(tracer, cam, is, {}, nullptr, &record);
    Image weights(cam.width, cam.height, {"R", "G", "B"});
    for (size_t i = 0; i < weights.pixels.size(); ++i) weights.pixels[i] = (i % 7 == 3) ? 0.0f : float(i % 5) - 1.5f;
    SceneGradients grads = SceneGradients::zeros_like(s);
    render_path_backward(tracer, cam, is, weights, grads, {}, &record);
    // Reference: the samples one by one (the camera ray as render_path draws it),
    // into one buffer per tile, the tiles added in order (as render/tile_reduce.h does).
    SceneGradients ref = SceneGradients::zeros_like(s);
    const int side = gradient_tile_side(cam.width, cam.height);
    for (int ty = 0; ty < cam.height; ty += side)
      for (int tx = 0; tx < cam.width; tx += side) {
        GradientTile tile(ref, s.environment);
        for (int y = ty; y < std::min(cam.height, ty + side); ++y)
          for (int x = tx; x < std::min(cam.width, tx + side); ++x) {
            Vec3 sum(0.0f);
            const Vec3 dI(weights.at(x, y, 0), weights.at(x, y, 1), weights.at(x, y, 2));
            for (int k = 0; k < spp; ++k) {
              const uint64_t pixel = cam.full_pixel_index(x, y);
              PathRng jitter(make_path_key(is.seed, pixel, uint32_t(k)), ~uint64_t(0), 0);
              const Ray ray = cam.generate_ray(filter.position(x, jitter.at(0)), filter.position(y, jitter.at(1)));
              const Vec3 L = tracer.sample_radiance(ray, pixel, uint32_t(k), is);
              sum += L;
              if (dI.x != 0.0f || dI.y != 0.0f || dI.z != 0.0f)
                tracer.sample_adjoint(ray, pixel, uint32_t(k), is, PathAdjoint{L, dI * (1.0f / float(spp)), &tile});
            }
            ASSERT_EQ(img.at(x, y, 0), sum.x * (1.0f / float(spp))) << x << " " << y;
            ASSERT_EQ(img.at(x, y, 2), sum.z * (1.0f / float(spp))) << x << " " << y;
          }
        tile.finish();
        tile.add_to(ref);
      }
    expect_same_floats(grads, ref);
  }
}

TEST(GradientTile, ReplayFromKeptWalksGivesTheSameFloats) {
  // The primal keeps each path's walks (the hits handed to the interaction
  // builder, the mesh that ended them, the escapes); a replay that reads them
  // instead of walking rebuilds the same interactions, so the gradients are equal
  // bit for bit: with every path kept, with only some (a budget of a few small
  // chunks), and in both interaction modes. Meshes end walks (the floor), rays
  // escape to the environment, and paths reach 3 bounces.
  for (InteractionMode mode : {InteractionMode::Aggregate, InteractionMode::Discrete}) {
    Scene scene = lit_tile_scene();
    scene.integrator.max_bounces = 3;
    scene.integrator.interaction.mode = mode;
    ReplaySetup r(std::move(scene));
    WalkStore all, some(size_t(12) << 10, size_t(2) << 10);  // 6 chunks of 2 KB
    r.record.walks = &all;
    render_path(r.tracer, r.cam, r.is, {}, nullptr, &r.record);
    ReplayCache some_walks = ReplayCache::walks_only(&some);
    render_path(r.tracer, r.cam, r.is, {}, nullptr, &some_walks);
    const size_t samples = size_t(r.cam.width) * r.cam.height * r.is.spp;
    ASSERT_EQ(all.size(), samples);
    EXPECT_EQ(all.kept(), samples);
    EXPECT_GT(some.kept(), samples / 50);
    EXPECT_LT(some.kept(), samples / 2);
    EXPECT_LE(some.bytes(), size_t(12) << 10);
    // Kept paths hold hits and mesh ends (not only escapes).
    size_t hits = 0, meshes = 0;
    for (size_t i = 0; i < samples; ++i) {
      PathWalkReader reader = all.path(i);
      std::vector<GaussianHit> h;
      WalkEnd end;
      if (reader.next(&h, &end)) hits += h.size(), meshes += end.mesh.valid;
    }
    EXPECT_GT(hits, samples);
    EXPECT_GT(meshes, samples / 10);

    SceneGradients traced = SceneGradients::zeros_like(r.s), kept = traced, partly = traced, walks_only = traced;
    const ReplayCache no_walks = r.parts(true, true), some_kept = r.parts(true, true, &some),
                      all_walks = r.parts(true, false, &all);
    render_path_backward(r.tracer, r.cam, r.is, r.weights, traced, {}, &no_walks);
    render_path_backward(r.tracer, r.cam, r.is, r.weights, kept, {}, &r.record);
    render_path_backward(r.tracer, r.cam, r.is, r.weights, partly, {}, &some_kept);
    render_path_backward(r.tracer, r.cam, r.is, r.weights, walks_only, {}, &all_walks);
    expect_same_floats(traced, kept);
    expect_same_floats(traced, partly);
    expect_same_floats(traced, walks_only);
    double sum = 0.0;
    for (const Vec3& a : traced.gaussian_albedo) sum += std::fabs(a.x);
    EXPECT_GT(sum, 0.0);
    // A store of another render's size is refused.
    WalkStore other;
    other.reset(7);
    const ReplayCache other_walks = r.parts(true, true, &other);
    EXPECT_THROW(render_path_backward(r.tracer, r.cam, r.is, r.weights, kept, {}, &other_walks), Error);
  }
}
