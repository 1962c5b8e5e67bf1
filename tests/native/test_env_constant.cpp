// The constant environment (lights/env_constant.h) against independent
// references: its density integrated over the sphere by quadrature, the moments
// of uniform-sphere sampling, a furnace-style plane under it against quadrature
// of the BRDF, and its colour gradient through the path replay against central
// differences. Also the EnvironmentLight plumbing around it (deep copies, the
// scene-JSON form, the lat-long raster).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "ptir/material/bsdf.h"
#include "ptir/math/rng.h"
#include "ptir/render/render_path.h"
#include "ptir/scene/scene_json.h"
#include "test_scenes.h"

using namespace ptir;

namespace {

constexpr double kPiD = 3.14159265358979323846;

// A camera at `eye` looking down -z, square image.
Camera looking_down(Vec3 eye, float fov, int size) {
  float m[16] = {1, 0, 0, eye.x, 0, 1, 0, eye.y, 0, 0, 1, eye.z, 0, 0, 0, 1};
  return make_camera(m, fov, size, size);
}

// Directional albedo integral of f~(wo, wi) over the upper hemisphere (midpoint rule
// in (cos theta, phi)), times a constant radiance.
Vec3 reflected_constant(BsdfModel model, const MaterialParams& params, Vec3 wo, Vec3 L) {
  const Bsdf bsdf(resolve_bsdf(model, SurfaceShader::PrincipledGGX), params, wo);
  const int n_mu = 400, n_phi = 800;
  Vec3 sum(0.0f);
  const double dmu = 1.0 / n_mu, dphi = 2.0 * kPiD / n_phi;
  for (int i = 0; i < n_mu; ++i) {
    float mu = float((i + 0.5) * dmu), s = std::sqrt(1 - mu * mu);
    for (int j = 0; j < n_phi; ++j) {
      float phi = float((j + 0.5) * dphi);
      sum += bsdf.eval(Vec3(s * std::cos(phi), s * std::sin(phi), mu)) * float(dmu * dphi);
    }
  }
  return sum * L;
}

using test::centre_mean;

}  // namespace

TEST(ConstantEnvironment, EvalIsColourTimesStrengthEverywhere) {
  ConstantEnvironment env(Vec3(0.5f, 1.0f, 2.0f), 3.0f);
  std::mt19937 rng(1);
  std::normal_distribution<float> g;
  for (int i = 0; i < 100; ++i) {
    Vec3 L = env.eval(Vec3(g(rng), g(rng), g(rng)));
    EXPECT_EQ(L.x, 1.5f);
    EXPECT_EQ(L.y, 3.0f);
    EXPECT_EQ(L.z, 6.0f);
  }
  EXPECT_STREQ(env.type(), "color");
  EXPECT_EQ(env.parameter_count(), 3u);
  Image img = env.to_latlong(8, 4);
  ASSERT_EQ(img.width, 8);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x) EXPECT_EQ(img.at(x, y, 2), 6.0f);
  EXPECT_THROW(ConstantEnvironment(Vec3(1.0f), -1.0f), Error);
  EXPECT_THROW(ConstantEnvironment(Vec3(NAN, 0, 0)), Error);
}

TEST(ConstantEnvironment, PdfIntegratesToOneAndMatchesSampling) {
  ConstantEnvironment env(Vec3(0.2f, 0.3f, 0.4f));
  // Quadrature over the sphere in (cos theta, phi): dω = dμ dφ.
  const int n_mu = 200, n_phi = 400;
  double integral = 0.0;
  for (int i = 0; i < n_mu; ++i) {
    double mu = -1.0 + (i + 0.5) * 2.0 / n_mu, s = std::sqrt(1 - mu * mu);
    for (int j = 0; j < n_phi; ++j) {
      double phi = (j + 0.5) * 2.0 * kPiD / n_phi;
      integral += env.pdf(Vec3(float(s * std::cos(phi)), float(s * std::sin(phi)), float(mu))) * (2.0 / n_mu) *
                  (2.0 * kPiD / n_phi);
    }
  }
  std::printf("  integral of pdf over the sphere: %.9f\n", integral);
  EXPECT_NEAR(integral, 1.0, 1e-5);
  // Samples: unit directions, density = pdf(wi), radiance = eval(wi); uniform-sphere
  // moments E[z] = E[x y] = 0, E[z^2] = E[x^2] = 1/3 (N = 200000: sd ~ 0.0013).
  Rng rng(7);
  const int n = 200000;
  double mz = 0, mzz = 0, mxx = 0, mxy = 0;
  for (int k = 0; k < n; ++k) {
    EnvLightSample s = env.sample_li(rng.next(), rng.next(), rng.next());
    ASSERT_TRUE(s.valid());
    ASSERT_NEAR(length(s.wi), 1.0f, 1e-5f);
    ASSERT_EQ(s.pdf, env.pdf(s.wi));
    ASSERT_EQ(s.Li.y, env.eval(s.wi).y);
    mz += s.wi.z;
    mzz += s.wi.z * s.wi.z;
    mxx += s.wi.x * s.wi.x;
    mxy += s.wi.x * s.wi.y;
  }
  std::printf("  E[z] %.5f  E[xy] %.5f  E[z^2] %.5f  E[x^2] %.5f (uniform sphere: 0 0 1/3 1/3)\n", mz / n, mxy / n,
              mzz / n, mxx / n);
  EXPECT_NEAR(mz / n, 0.0, 0.006);
  EXPECT_NEAR(mxy / n, 0.0, 0.003);
  EXPECT_NEAR(mzz / n, 1.0 / 3.0, 0.004);
  EXPECT_NEAR(mxx / n, 1.0 / 3.0, 0.004);
}

TEST(ConstantEnvironment, PlaneFurnaceMatchesQuadrature) {
  // A large plane under a constant sky, direct light only: the reflected radiance
  // is the BRDF's directional albedo times the sky (MIS of light and BRDF samples).
  for (BsdfModel model : {BsdfModel::PrincipledV1, BsdfModel::DisneySimplified})
    for (float metallic : {0.0f, 1.0f}) {
      Scene scene;
      TriangleMesh floor = test::quad_z(0.0f, 50.0f);
      floor.material.base_colour = Vec3(0.9f, 0.7f, 0.5f);
      floor.material.roughness = 0.5f;
      floor.material.metallic = metallic;
      scene.meshes.push_back(floor);
      const Vec3 sky(0.6f, 0.8f, 1.0f);
      scene.environment = ConstantEnvironment(sky, 1.5f);
      PathTracer tracer(scene);
      IntegratorSettings settings;
      settings.spp = 512;
      settings.max_bounces = 0;
      settings.brdf = model;
      Image img = render_path(tracer, looking_down(Vec3(0, 0, 2.0f), 0.02f, 9), settings);
      MaterialParams params;
      params.albedo = floor.material.base_colour;
      params.roughness = 0.5f;
      params.metallic = metallic;
      Vec3 expected = reflected_constant(model, params, Vec3(0, 0, 1), sky * 1.5f);
      std::printf("  %s metallic %.0f: render %.5f %.5f %.5f, quadrature %.5f %.5f %.5f\n", to_string(model),
                  metallic, centre_mean(img, 0, 4), centre_mean(img, 1, 4), centre_mean(img, 2, 4), expected.x, expected.y,
                  expected.z);
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(centre_mean(img, c, 4), expected[c], 0.02 * expected[c])
            << to_string(model) << " metallic " << metallic << " channel " << c;
    }
}

TEST(ConstantEnvironment, ColourGradientMatchesFiniteDifferences) {
  // Gaussians over a floor under a constant sky, 2 bounces. Uniform sampling does not
  // depend on the colour, so with a fixed seed the render is exactly linear in it and
  // central differences are exact up to rounding.
  Scene scene;
  *scene.gaussians = test::gaussian_sphere(3000, 0.5f, Vec3(0.7f, 0.5f, 0.3f), 0.4f, 0.0f);
  TriangleMesh floor = test::quad_z(-0.6f, 4.0f);
  floor.material.base_colour = Vec3(0.6f, 0.6f, 0.6f);
  scene.meshes.push_back(floor);
  scene.environment = ConstantEnvironment(Vec3(0.4f, 0.6f, 0.9f), 1.2f);
  IntegratorSettings settings;
  settings.spp = 4;
  settings.max_bounces = 2;
  settings.seed = 5;
  settings.russian_roulette = false;  // path replay's requirement
  Camera cam = looking_down(Vec3(0.1f, 0.0f, 2.5f), 0.9f, 16);
  Image weights(16, 16, {"R", "G", "B"});
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (float& w : weights.pixels) w = u(rng);
  auto loss = [&](const Scene& s) {
    PathTracer tracer(s);
    Image img = render_path(tracer, cam, settings);
    double l = 0;
    for (size_t p = 0; p < size_t(16 * 16); ++p)
      for (int c = 0; c < 3; ++c) l += double(weights.pixels[3 * p + c]) * img.pixels[4 * p + c];
    return l;
  };
  PathTracer tracer(scene);
  SceneGradients g = SceneGradients::zeros_like(scene);
  ASSERT_EQ(g.environment.size(), 3u);
  render_path_backward(tracer, cam, settings, weights, g);
  for (int c = 0; c < 3; ++c) {
    const float h = 0.05f;
    Scene plus = scene, minus = scene;
    Vec3 k = scene.environment.as<ConstantEnvironment>()->colour();
    Vec3 kp = k, km = k;
    kp[c] += h;
    km[c] -= h;
    plus.environment.as<ConstantEnvironment>()->set_colour(kp);
    minus.environment.as<ConstantEnvironment>()->set_colour(km);
    // The copies are deep: the original keeps its colour.
    ASSERT_EQ(scene.environment.as<ConstantEnvironment>()->colour()[c], k[c]);
    double fd = (loss(plus) - loss(minus)) / (2.0 * h);
    std::printf("  channel %d: replay gradient %.7g, central difference %.7g\n", c, g.environment[size_t(c)], fd);
    EXPECT_NEAR(g.environment[size_t(c)], fd, 1e-3 * std::fabs(fd) + 1e-4) << "channel " << c;
    EXPECT_GT(std::fabs(fd), 1e-2);
  }
  // The optimiser's raw view: colour = exp(raw), d/draw = d/dcolour * colour.
  const ConstantEnvironment& env = *scene.environment.as<ConstantEnvironment>();
  float raw[3], d_raw[3];
  env.get_raw(raw);
  env.raw_gradient(raw, g.environment.data(), d_raw);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(std::exp(raw[c]), env.colour()[c], 1e-6f);
    EXPECT_NEAR(d_raw[c], g.environment[size_t(c)] * env.colour()[c], 1e-5f * std::fabs(d_raw[c]) + 1e-7f);
  }
}

TEST(ConstantEnvironment, SceneJsonColourFormAndDeepCopies) {
  Scene s = scene_from_json_string(R"({"environment": {"type": "color", "color": [0.5, 1, 2], "strength": 2}})", "");
  const ConstantEnvironment* k = s.environment.as<ConstantEnvironment>();
  ASSERT_TRUE(k);
  EXPECT_EQ(k->colour().y, 1.0f);
  EXPECT_EQ(k->strength(), 2.0f);
  EXPECT_EQ(s.environment->eval(Vec3(0, 0, 1)).z, 4.0f);
  // A copied scene owns its own environment.
  Scene copy = s;
  copy.environment.as<ConstantEnvironment>()->set_colour(Vec3(0.0f));
  EXPECT_EQ(s.environment->eval(Vec3(1, 0, 0)).x, 1.0f);
  EXPECT_EQ(copy.environment->eval(Vec3(1, 0, 0)).x, 0.0f);
}
