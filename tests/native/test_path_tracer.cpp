// The path tracer against independent references: numerical quadrature of the
// BRDF times the incident light (area light, environment map), a white-sphere
// furnace, and replay determinism across thread counts.
#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include "ptir/material/bsdf.h"
#include "ptir/render/render_path.h"
#include "ptir/transport/scattering.h"
#include "test_scenes.h"

using namespace ptir;

namespace {

// A camera at `eye` looking down -z, square image.
Camera looking_down(Vec3 eye, float fov, int size) {
  float m[16] = {1, 0, 0, eye.x, 0, 1, 0, eye.y, 0, 0, 1, eye.z, 0, 0, 0, 1};
  return make_camera(m, fov, size, size);
}

TriangleMesh floor_quad(float h, Vec3 colour, float roughness, float metallic) {
  TriangleMesh m = test::quad_z(0.0f, h);
  m.material.base_colour = colour;
  m.material.roughness = roughness;
  m.material.metallic = metallic;
  return m;
}

// Reflected radiance toward wo at the origin of a z-up surface: integral of
// f~(wo, wi) L(wi) over the hemisphere by midpoint quadrature in (cos theta, phi).
template <class Radiance>
Vec3 quadrature(BsdfModel model, const MaterialParams& params, Vec3 wo, Radiance&& L, int n_theta = 400,
                int n_phi = 800) {
  const Bsdf bsdf(resolve_bsdf(model, SurfaceShader::PrincipledGGX), params, wo);
  Vec3 sum(0.0f);
  double dmu = 1.0 / n_theta, dphi = 2.0 * kPi / n_phi;
  for (int i = 0; i < n_theta; ++i) {
    float mu = float((i + 0.5) * dmu), s = std::sqrt(1 - mu * mu);
    for (int j = 0; j < n_phi; ++j) {
      float phi = float((j + 0.5) * dphi);
      Vec3 wi(s * std::cos(phi), s * std::sin(phi), mu);
      // f~ already includes the cosine; d(omega) = d(mu) d(phi).
      sum += bsdf.eval(wi) * L(wi) * float(dmu * dphi);
    }
  }
  return sum;
}

using test::centre_mean;

// The scene under a uniform white sky (radiance 1), path-traced.
Image render_under_white_sky(Scene& scene, const IntegratorSettings& settings, const Camera& cam) {
  scene.environment = Environment::constant(Vec3(1.0f), 8, 4);
  PathTracer tracer(scene);
  return render_path(tracer, cam, settings);
}

}  // namespace

TEST(PathTracer, PlaneUnderAreaLightMatchesQuadrature) {
  // Direct light only: a glossy plane under a square area light; MIS combines light
  // and BRDF sampling, the reference integrates f~ L over the light's solid angle.
  for (BsdfModel model : {BsdfModel::PrincipledV1, BsdfModel::DisneySimplified})
  for (float roughness : {0.3f, 0.8f}) {
    Scene scene;
    scene.meshes.push_back(floor_quad(50.0f, Vec3(0.7f, 0.5f, 0.3f), roughness, 0.0f));
    Affine light_xf;
    light_xf.translation = Vec3(0.3f, 0.0f, 1.0f);  // local -z points down
    AreaLight light = AreaLight::from_blender(light_xf, AreaShape::Rectangle, 0.5f, 0.5f, 40.0f, Vec3(1.0f));
    scene.emitters.push_back(light);
    PathTracer tracer(scene);
    IntegratorSettings settings;
    settings.spp = 256;
    settings.max_bounces = 0;
    settings.brdf = model;
    Camera cam = looking_down(Vec3(0, 0, 2.0f), 0.02f, 9);  // a narrow view of the origin
    Image img = render_path(tracer, cam, settings);

    MaterialParams brdf{Vec3(0.7f, 0.5f, 0.3f), roughness, 0.0f};
    Vec3 wo(0, 0, 1);
    float Le = light.radiance.x;
    Vec3 expected = quadrature(model, brdf, wo, [&](Vec3 wi) {
      // Does the direction from the origin hit the light square at z = 1?
      if (wi.z <= 0) return 0.0f;
      float t = 1.0f / wi.z;
      Vec3 q = wi * t;
      return (std::fabs(q.x - 0.3f) <= 0.25f && std::fabs(q.y) <= 0.25f) ? Le : 0.0f;
    }, 1200, 1200);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(centre_mean(img, c, 4), expected[c], 0.02 * expected[c]) << to_string(model) << " roughness " << roughness;
  }
}

TEST(PathTracer, PlaneUnderEnvironmentMatchesQuadrature) {
  // A non-uniform environment (bright band + gradient) over a metallic and a
  // dielectric plane; one bounce cannot add anything (nothing else in the scene).
  Image map(64, 32, {"R", "G", "B"});
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 64; ++x) {
      float band = (x >= 20 && x < 28 && y >= 6 && y < 12) ? 20.0f : 0.0f;
      map.at(x, y, 0) = 0.2f + band + 0.02f * x;
      map.at(x, y, 1) = 0.3f + band;
      map.at(x, y, 2) = 0.5f + 0.5f * band + 0.01f * y;
    }
  for (BsdfModel model : {BsdfModel::PrincipledV1, BsdfModel::DisneySimplified})
  for (float metallic : {0.0f, 1.0f}) {
    Scene scene;
    scene.meshes.push_back(floor_quad(50.0f, Vec3(0.8f, 0.6f, 0.4f), 0.4f, metallic));
    scene.environment = Environment(map, 1.5f, 0.3f);
    PathTracer tracer(scene);
    IntegratorSettings settings;
    settings.spp = 512;
    settings.max_bounces = 1;
    settings.brdf = model;
    Camera cam = looking_down(Vec3(0, 0, 2.0f), 0.02f, 9);
    Image img = render_path(tracer, cam, settings);
    MaterialParams brdf{Vec3(0.8f, 0.6f, 0.4f), 0.4f, metallic};
    const Environment& env = *scene.environment.as<Environment>();
    Vec3 expected = quadrature(model, brdf, Vec3(0, 0, 1), [&](Vec3 wi) { return env.eval(wi); }, 800, 1600);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(centre_mean(img, c, 4), expected[c], 0.03 * expected[c]) << to_string(model) << " metallic " << metallic;
  }
}

TEST(PathTracer, WhiteGaussianSphereFurnace) {
  // A closed sphere of white Gaussians (albedo 1, metallic 0) in a uniform
  // environment of radiance 1. The sphere is convex, so every point sees the
  // whole environment: the radiance is the BSDF's directional albedo, close to 1.
  // The simplified Disney model stays <= 1 at normal incidence (Schlick Fresnel
  // moves energy between the lobes, GGX loses a little); Cycles' Principled v1
  // adds its lobes uncoupled and reflects ~1.04 (test_principled.cpp's table).
  for (BsdfModel model : {BsdfModel::PrincipledV1, BsdfModel::DisneySimplified}) {
  Scene scene;
  *scene.gaussians = test::gaussian_sphere(40000, 1.0f, Vec3(1.0f), 0.5f, 0.0f);
  IntegratorSettings settings;
  settings.spp = 64;
  settings.max_bounces = 3;
  settings.brdf = model;
  Image img = render_under_white_sky(scene, settings, looking_down(Vec3(0, 0, 4.0f), 0.6f, 32));
  // Pixels well inside the silhouette (full coverage, not grazing).
  double sum = 0, max_v = 0;
  int n = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      float dx = (x + 0.5f) / 32 - 0.5f, dy = (y + 0.5f) / 32 - 0.5f;
      if (dx * dx + dy * dy > 0.15f * 0.15f) continue;
      ASSERT_EQ(img.at(x, y, 3), 1.0f);
      sum += img.at(x, y, 0);
      max_v = std::max(max_v, double(img.at(x, y, 0)));
      n++;
    }
  ASSERT_GT(n, 50);
  double mean = sum / n;
  MaterialParams brdf{Vec3(1.0f), 0.5f, 0.0f};
  double albedo_normal = quadrature(model, brdf, Vec3(0, 0, 1), [](Vec3) { return 1.0f; }).x;
  EXPECT_NEAR(mean, albedo_normal, 0.03) << to_string(model) << ": directional albedo at normal incidence " << albedo_normal;
  EXPECT_GT(mean, 0.9);
  EXPECT_LT(mean, (model == BsdfModel::PrincipledV1 ? 1.06 : 1.0) + 0.02);
  }
}

namespace {

// A flat square layer of overlapping splats at height z (spacing 0.1, half-size h),
// every normal +z.
void add_splat_layer(GaussianField& f, float z, float h, Vec3 albedo, float roughness) {
  const Frame up(Vec3(0, 0, 1));
  for (float x = -h; x <= h; x += 0.1f)
    for (float y = -h; y <= h; y += 0.1f) {
      test::add_gaussian(f, Vec3(x, y, z), Vec3(0.07f, 0.07f, 1e-4f), test::quat_from_frame(up), 0.99f, albedo, roughness);
      f.normal.back() = Vec3(0, 0, 1);
    }
}

}  // namespace

TEST(PathTracer, SplatLayerSeenFromBehindCastsShadowLikeAMesh) {
  // A splat floor under a black roof 1 above it, in a white sky. The roof is a
  // splat layer whose normals face up, away from the floor, as the far side of a
  // closed object's field faces away from a ray that entered it (or as a fitted
  // field's hidden splats often do). A mesh occludes from both sides; so must the
  // splats: the floor under it must be as dark as under a mesh roof (the
  // reference), far darker than under the open sky. The paper's rule (every
  // back-facing hit of a spawned ray is skipped, self_range_scale = inf) lets the
  // sky through the roof and renders the open-sky value.
  const auto floor_radiance = [](bool mesh_roof, float self_range_scale) {
    Scene scene;
    scene.gaussians->normals_from_file = true;
    add_splat_layer(*scene.gaussians, 0.0f, 6.0f, Vec3(0.5f), 1.0f);
    if (mesh_roof) {
      TriangleMesh roof = test::quad_z(1.0f, 3.0f);
      roof.material.base_colour = Vec3(0.0f);
      roof.material.roughness = 1.0f;
      scene.meshes.push_back(roof);
    } else {
      add_splat_layer(*scene.gaussians, 1.0f, 3.0f, Vec3(0.0f), 1.0f);
    }
    IntegratorSettings settings;
    settings.spp = 256;
    settings.max_bounces = 2;
    settings.self_range_scale = self_range_scale;
    // Seen from between the floor and the roof.
    Image img = render_under_white_sky(scene, settings, looking_down(Vec3(0, 0, 0.5f), 0.05f, 9));
    return centre_mean(img, 0, 4);
  };
  const double mesh = floor_radiance(true, IntegratorSettings{}.self_range_scale);
  const double splats = floor_radiance(false, IntegratorSettings{}.self_range_scale);
  const double paper_rule = floor_radiance(false, std::numeric_limits<float>::infinity());
  std::printf("floor under: mesh roof %.4f, splat roof %.4f, splat roof by the paper's rule %.4f\n", mesh, splats, paper_rule);
  // Under a 6 x 6 roof at height 1 the floor sees the sky only below ~18 degrees.
  EXPECT_LT(mesh, 0.1) << "mesh roof";
  EXPECT_NEAR(splats, mesh, 0.1 * mesh + 0.005) << "splat roof seen from behind, default self range";
  EXPECT_GT(paper_rule, 2.0 * mesh) << "the paper's rule should let the sky through (else this test cannot fail)";
}

TEST(PathTracer, SplatNormalSignsDoNotMatter) {
  // Two-sided splats (issue #36): a trainer's PLY has no normals, and the sign the engine
  // gives each shortest axis (camera votes, or away from the centroid) is a guess. The
  // image must not depend on it: flipping every other Gaussian's normal (neighbours then
  // disagree everywhere) gives the same floats, direct light, shadows and bounces alike.
  // Before, the flipped splats shadowed themselves and cancelled their neighbours' normals.
  Scene scene;
  *scene.gaussians = test::gaussian_sphere(3000, 0.5f, Vec3(0.6f, 0.5f, 0.4f), 0.4f, 0.0f);
  scene.gaussians->normals_from_file = false;  // a trainer's PLY: axes without a sign (two-sided)
  scene.meshes.push_back(floor_quad(5.0f, Vec3(0.5f), 0.7f, 0.0f));
  for (int k : {0, 1, 2, 3}) scene.meshes.back().vertices[k].z = -0.6f;
  Affine light_xf;
  light_xf.translation = Vec3(0.5f, 0.0f, 2.0f);
  scene.emitters.push_back(AreaLight::from_blender(light_xf, AreaShape::Ellipse, 1.0f, 1.0f, 200.0f, Vec3(1.0f)));
  scene.environment = Environment::constant(Vec3(0.2f, 0.3f, 0.4f), 16, 8);
  IntegratorSettings settings;
  settings.spp = 4;
  settings.max_bounces = 2;
  const Camera cam = looking_down(Vec3(0.3f, 0.2f, 3.0f), 0.6f, 32);
  const Image a = render_path(PathTracer(scene), cam, settings);
  for (size_t i = 0; i < scene.gaussians->size(); i += 2) scene.gaussians->normal[i] = -scene.gaussians->normal[i];
  const Image b = render_path(PathTracer(scene), cam, settings);
  EXPECT_EQ(a.pixels, b.pixels);
  double sum = 0.0;
  for (float v : a.pixels) sum += v;
  EXPECT_GT(sum / double(a.pixels.size()), 0.05) << "test design: a lit image";
}

TEST(PathTracer, SameSeedSameImageAnyThreadCount) {
  Scene scene;
  *scene.gaussians = test::gaussian_sphere(5000, 0.5f, Vec3(0.6f, 0.4f, 0.3f), 0.4f, 0.2f);
  scene.meshes.push_back(floor_quad(5.0f, Vec3(0.5f), 0.7f, 0.0f));
  scene.meshes.back().vertices[0].z = scene.meshes.back().vertices[1].z = -0.6f;
  scene.meshes.back().vertices[2].z = scene.meshes.back().vertices[3].z = -0.6f;
  Affine light_xf;
  light_xf.translation = Vec3(0.0f, 0.0f, 2.0f);
  scene.emitters.push_back(AreaLight::from_blender(light_xf, AreaShape::Ellipse, 1.0f, 1.0f, 200.0f, Vec3(1.0f)));
  scene.environment = Environment::constant(Vec3(0.2f, 0.3f, 0.4f), 16, 8);
  PathTracer tracer(scene);
  IntegratorSettings settings;
  settings.spp = 4;
  settings.max_bounces = 3;
  settings.seed = 7;
  Camera cam = looking_down(Vec3(0.2f, 0.1f, 3.0f), 0.9f, 40);
  Image a, b, c;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    a = render_path(tracer, cam, settings);
  }
  b = render_path(tracer, cam, settings);
  EXPECT_EQ(a.pixels, b.pixels);
  settings.seed = 8;
  c = render_path(tracer, cam, settings);
  EXPECT_NE(a.pixels, c.pixels);
}

TEST(PathTracer, OneLightAndRouletteKeepTheExpectation) {
  // Cycles' estimator (one light picked uniformly per vertex, Russian roulette past
  // the first vertex) against every light at every vertex without roulette: the same
  // image in expectation, with ~1 shadow ray per vertex instead of N and fewer
  // vertices. A glossy floor reflects a near area light, so the MIS weights matter.
  // Same seed for both (the same camera rays): measured, the blocks agree to 0.6 %
  // and the whole image to 0.15 %; leaving the pick's 1/N out of the BSDF side's MIS
  // weight moves a block by 3.3 % and the image by 0.7 %, out of the estimate by 3x.
  Scene scene;
  *scene.gaussians = test::gaussian_sphere(6000, 0.4f, Vec3(0.7f, 0.5f, 0.3f), 0.35f, 0.0f);
  scene.meshes.push_back(floor_quad(6.0f, Vec3(0.6f, 0.6f, 0.5f), 0.25f, 0.0f));
  for (int i = 0; i < 4; ++i) scene.meshes.back().vertices[size_t(i)].z = -0.45f;
  Affine light_xf;
  light_xf.translation = Vec3(0.6f, 0.2f, 0.9f);
  scene.emitters.push_back(AreaLight::from_blender(light_xf, AreaShape::Rectangle, 0.6f, 0.4f, 60.0f, Vec3(1.0f)));
  scene.emitters.push_back(PointLight::from_blender(Vec3(-1.0f, -0.5f, 1.2f), 150.0f, Vec3(1.0f, 0.8f, 0.6f), 0.1f));
  scene.environment = Environment::constant(Vec3(0.3f, 0.35f, 0.45f), 16, 8);
  PathTracer tracer(scene);
  Camera cam = looking_down(Vec3(0.1f, 0.0f, 3.0f), 1.0f, 24);

  auto render = [&](LightSelection selection, bool roulette, uint64_t seed, PathStats* stats) {
    IntegratorSettings s;
    s.spp = 384;
    s.max_bounces = 3;
    s.seed = seed;
    s.light_selection = selection;
    s.russian_roulette = roulette;
    return render_path(tracer, cam, s, {}, stats);
  };
  PathStats all_stats, one_stats;
  const Image all = render(LightSelection::All, false, 1, &all_stats);
  const Image one = render(LightSelection::One, true, 1, &one_stats);
  // 3 x 3 blocks of 8 x 8 pixels and the whole image, per channel.
  for (int c = 0; c < 3; ++c) {
    double whole[2] = {0, 0};
    for (int by = 0; by < 3; ++by)
      for (int bx = 0; bx < 3; ++bx) {
        double m[2] = {0, 0};
        for (int y = by * 8; y < by * 8 + 8; ++y)
          for (int x = bx * 8; x < bx * 8 + 8; ++x) {
            m[0] += all.at(x, y, c) / 64.0;
            m[1] += one.at(x, y, c) / 64.0;
          }
        EXPECT_NEAR(m[1], m[0], 0.015 * m[0]) << "block " << bx << "," << by << " channel " << c;
        whole[0] += m[0] / 9.0, whole[1] += m[1] / 9.0;
      }
    EXPECT_NEAR(whole[1], whole[0], 0.005 * whole[0]) << "channel " << c;
  }
  // The work: every light (3) at every vertex against one; roulette ends paths early
  // (same seed: the same camera rays and first vertices; most later rays escape here).
  const double all_per_vertex = double(all_stats.shadow_rays) / double(all_stats.vertices);
  const double one_per_vertex = double(one_stats.shadow_rays) / double(one_stats.vertices);
  EXPECT_GT(all_per_vertex, 2.0);
  EXPECT_LE(one_per_vertex, 1.0);
  EXPECT_LT(double(one_stats.vertices), 0.995 * double(all_stats.vertices));
}

TEST(PathTracer, EscapeQueryMatchesTheNextEvent) {
  // Scatterer::escapes (the last ray's occlusion query, any hit order) against
  // next_event's kind == Escape (the ordered walk and the interaction rules): rays
  // from outside and inside a random field over two (non-emitting) quads, leaving
  // nothing or a Gaussian interaction (its back-facing hits skipped), with and
  // without the geometric criterion.
  Scene scene;
  *scene.gaussians = test::random_field(150, 53, 0.02f, 0.1f);
  scene.meshes = {test::quad_z(0.1f, 0.6f), test::quad_z(-0.5f, 0.4f)};
  SceneAccel accel(*scene.gaussians, scene.meshes);
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const auto direction = [&] { return normalize(Vec3(u(rng), u(rng), u(rng))); };
  for (bool criterion : {true, false}) {
    IntegratorSettings settings;
    settings.geometric_criterion = criterion;
    Scatterer scatterer(scene, accel, settings, 1e-5f);
    ASSERT_TRUE(scatterer.escape_query_applies());
    int escaped = 0, stopped = 0, from_gaussian = 0;
    for (int i = 0; i < 3000; ++i) {
      Ray r;
      const bool inside = i % 2 == 0;
      r.o = inside ? Vec3(u(rng), u(rng), u(rng)) * 0.8f : direction() * 3.0f;
      r.d = inside ? direction() : normalize(Vec3(u(rng), u(rng), u(rng)) * 0.7f - r.o);
      SpawnContext from;
      const uint64_t key = uint64_t(i) * 7919u + (criterion ? 1u : 0u);
      // Every third ray leaves the interaction the first one met.
      if (i % 3 == 0) {
        const NextEvent first = scatterer.next_event(r, from, key, 0);
        if (first.kind == NextEvent::Gaussian) {
          from = scatterer.spawn_context(first, r);
          r = scatterer.spawn_ray(from, direction());
          from_gaussian++;
        }
      }
      const bool expected = scatterer.next_event(r, from, key, 3).kind == NextEvent::Escape;
      EXPECT_EQ(scatterer.escapes(r, from, key, 3), expected) << "ray " << i << (criterion ? "" : ", no criterion");
      (expected ? escaped : stopped)++;
    }
    EXPECT_GT(escaped, 500);
    EXPECT_GT(stopped, 500);
    EXPECT_GT(from_gaussian, 100) << escaped << " escaped, " << stopped << " stopped";
  }
}

TEST(PathTracer, IndirectFromFieldEndsOnTheSplatsRadiance) {
  // A grey splat floor under a splat ceiling 1 above it (normals down, albedo 0),
  // in a black sky: path-traced, nothing lights the floor. With the ceiling's SH
  // holding a radiance R (what the photos of a lit ceiling would have fitted), the
  // inversion's bounce light from the field makes the floor reflect R from every
  // direction the ceiling covers: the BSDF's quadrature over the ceiling's solid
  // angle, times R.
  const float R = 0.6f, h = 3.0f;
  Scene scene;
  scene.gaussians->normals_from_file = true;
  add_splat_layer(*scene.gaussians, 0.0f, 6.0f, Vec3(0.5f), 0.5f);
  const size_t floor_count = scene.gaussians->size();
  add_splat_layer(*scene.gaussians, 1.0f, h, Vec3(0.0f), 1.0f);
  GaussianField& f = *scene.gaussians;
  const float dc = ((R <= 0.0031308f ? 12.92f * R : 1.055f * std::pow(R, 1.0f / 2.4f) - 0.055f) - 0.5f) / 0.28209479f;
  for (size_t i = floor_count; i < f.size(); ++i) {
    f.normal[i] = Vec3(0, 0, -1);
    for (int c = 0; c < 3; ++c) f.sh[i * 3 + c] = dc;  // degree 0: the DC term per channel
  }
  scene.environment = Environment::constant(Vec3(0.0f), 8, 4);
  IntegratorSettings settings;
  settings.spp = 256;
  settings.max_bounces = 2;
  const Camera cam = looking_down(Vec3(0, 0, 0.5f), 0.05f, 9);
  PathTracer tracer(scene);
  const double path_traced = centre_mean(render_path(tracer, cam, settings), 0, 4);
  settings.indirect_from_field = true;
  const double from_field = centre_mean(render_path(tracer, cam, settings), 0, 4);
  // The ceiling covers the directions with |wi.x|, |wi.y| <= h wi.z (seen from the floor's centre, 1 below).
  const MaterialParams floor_brdf{Vec3(0.5f), 0.5f, 0.0f};
  const double expected = R * quadrature(BsdfModel::PrincipledV1, floor_brdf, Vec3(0, 0, 1), [h](Vec3 wi) {
                                return std::fabs(wi.x) <= h * wi.z && std::fabs(wi.y) <= h * wi.z ? 1.0f : 0.0f;
                              }).x;
  std::printf("floor: path-traced %.4f, bounce light from the field %.4f, quadrature %.4f\n", path_traced, from_field,
              expected);
  EXPECT_LT(path_traced, 1e-6);
  EXPECT_NEAR(from_field, expected, 0.03 * expected);
}
