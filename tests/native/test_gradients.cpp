// Path replay backpropagation against central finite differences of the primal
// estimator computed with the same random numbers, for every differentiable
// parameter kind, on a small scene with indirect light (2 bounces) and shadows:
// a Gaussian sphere on a mesh floor, an area light, an environment.
//
// Albedo, mesh colour and environment texels do not change any sampling
// decision (directions, densities, MIS weights and visibility depend on
// roughness, metallic, geometry and the sampling tables, which stay fixed), so the
// primal estimator is smooth in them and PRB must match the difference quotient
// to float precision (bound 0.5%). The same holds for metallic under the
// simplified Disney model (its lobe choice is a fixed 1/2), which is how metallic
// is checked exactly. Roughness, SG amplitudes and, under the Principled BSDF
// (whose lobe probability follows metallic), metallic also move the sampled
// directions / lobe choice, which PRB holds fixed by design: there the two agree
// in expectation only, so they are compared on many samples.
#include <gtest/gtest.h>

#include <functional>
#include <random>

#include "ptir/optim/light_balance.h"
#include "ptir/render/render_path.h"
#include "test_scenes.h"

using namespace ptir;

namespace {

struct GradientScene {
  Scene scene;
  Camera camera;
  Image weights;  // the loss is sum(weights * image)
};

GradientScene make_scene(bool sg_environment) {
  GradientScene gs;
  Scene& s = gs.scene;
  *s.gaussians = test::gaussian_sphere(3000, 0.5f, Vec3(0.6f, 0.5f, 0.4f), 0.45f, 0.3f);
  // Vary the materials so every Gaussian is different.
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.2f, 0.8f);
  for (size_t i = 0; i < s.gaussians->size(); ++i) {
    s.gaussians->albedo[i] = Vec3(u(rng), u(rng), u(rng));
    s.gaussians->roughness[i] = u(rng);
    s.gaussians->metallic[i] = 0.5f * u(rng);
  }
  TriangleMesh floor = test::quad_z(-0.5f, 4.0f);
  floor.material.base_colour = Vec3(0.7f, 0.6f, 0.5f);
  floor.material.roughness = 0.6f;
  floor.material.metallic = 0.1f;
  s.meshes.push_back(floor);
  Affine light_xf;
  light_xf.translation = Vec3(0.6f, 0.3f, 1.5f);
  s.emitters.push_back(AreaLight::from_blender(light_xf, AreaShape::Rectangle, 0.6f, 0.6f, 60.0f, Vec3(1.0f)));
  if (sg_environment) {
    s.environment = SgEnvironment(8, 0.3f, -1.0f);
  } else {
    Image map(16, 8, {"R", "G", "B"});
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 16; ++x) {
        map.at(x, y, 0) = 0.3f + 0.05f * x;
        map.at(x, y, 1) = 0.4f + 0.1f * y;
        map.at(x, y, 2) = (x == 3 && y == 2) ? 8.0f : 0.5f;
      }
    s.environment = Environment(map, 1.0f);
  }
  s.integrator.max_bounces = 2;
  // Camera above and in front, looking at the sphere.
  Vec3 eye(0.0f, -2.2f, 1.0f), target(0.0f, 0.0f, -0.1f);
  Vec3 back = normalize(eye - target), right = normalize(cross(Vec3(0, 0, 1), back)), up = cross(back, right);
  float m[16] = {right.x, up.x, back.x, eye.x, right.y, up.y, back.y, eye.y, right.z, up.z, back.z, eye.z, 0, 0, 0, 1};
  gs.camera = make_camera(m, 0.8f, 16, 16);
  gs.weights = Image(16, 16, {"R", "G", "B"});
  std::uniform_real_distribution<float> w(-1.0f, 1.0f);
  for (float& v : gs.weights.pixels) v = w(rng);
  return gs;
}

double loss(const Scene& scene, const Camera& cam, const IntegratorSettings& settings, const Image& weights) {
  PathTracer tracer(scene);
  Image img = render_path(tracer, cam, settings);
  double l = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int c = 0; c < 3; ++c) l += double(weights.at(x, y, c)) * img.at(x, y, c);
  return l;
}

SceneGradients prb(const Scene& scene, const Camera& cam, const IntegratorSettings& settings, const Image& weights) {
  PathTracer tracer(scene);
  SceneGradients g = SceneGradients::zeros_like(scene);
  render_path_backward(tracer, cam, settings, weights, g);
  return g;
}

// Central difference of the loss along a parameter perturbation `apply(scene, h)`.
double central_difference(const GradientScene& gs, const IntegratorSettings& settings, double h,
                          const std::function<void(Scene&, float)>& apply) {
  Scene plus = gs.scene, minus = gs.scene;
  plus.gaussians = std::make_shared<GaussianField>(*gs.scene.gaussians);
  minus.gaussians = std::make_shared<GaussianField>(*gs.scene.gaussians);
  apply(plus, float(h));
  apply(minus, float(-h));
  return (loss(plus, gs.camera, settings, gs.weights) - loss(minus, gs.camera, settings, gs.weights)) / (2 * h);
}

// Per channel: the replay's albedo gradient summed over the Gaussians against the
// difference quotient of moving every albedo at once (exact: see the top).
void expect_albedo_sums_match(const GradientScene& gs, const IntegratorSettings& settings, const SceneGradients& g) {
  for (int c = 0; c < 3; ++c) {
    double analytic = 0;
    for (const Vec3& a : g.gaussian_albedo) analytic += a[c];
    double fd = central_difference(gs, settings, 1e-2, [c](Scene& s, float h) {
      for (Vec3& a : s.gaussians->albedo) a[c] += h;
    });
    EXPECT_NEAR(analytic, fd, 5e-3 * std::fabs(fd) + 1e-4) << "albedo channel " << c;
    EXPECT_GT(std::fabs(fd), 1e-2);
  }
}

IntegratorSettings settings_with(int spp) {
  IntegratorSettings s;
  s.russian_roulette = false;  // path replay's requirement (render_path_backward)
  s.spp = spp;
  s.max_bounces = 2;
  s.seed = 3;
  return s;
}

}  // namespace

TEST(Gradients, GaussianAlbedoAndMetallicMatchFiniteDifferences) {
  GradientScene gs = make_scene(false);
  IntegratorSettings settings = settings_with(4);
  SceneGradients g = prb(gs.scene, gs.camera, settings, gs.weights);
  expect_albedo_sums_match(gs, settings, g);
  IntegratorSettings v2 = settings;  // Principled v2: its gradients too
  v2.brdf = BsdfModel::PrincipledV2;
  expect_albedo_sums_match(gs, v2, prb(gs.scene, gs.camera, v2, gs.weights));
  IntegratorSettings disney = settings;
  disney.brdf = BsdfModel::DisneySimplified;
  SceneGradients gd = prb(gs.scene, gs.camera, disney, gs.weights);
  double analytic_m = 0;
  for (float m : gd.gaussian_metallic) analytic_m += m;
  double fd_m = central_difference(gs, disney, 1e-2, [](Scene& s, float h) {
    for (float& m : s.gaussians->metallic) m += h;
  });
  EXPECT_NEAR(analytic_m, fd_m, 5e-3 * std::fabs(fd_m) + 1e-4);
  EXPECT_GT(std::fabs(fd_m), 1e-2);
  // One Gaussian on its own: the one with the largest albedo gradient.
  size_t best = 0;
  for (size_t i = 0; i < g.gaussian_albedo.size(); ++i)
    if (std::fabs(g.gaussian_albedo[i].y) > std::fabs(g.gaussian_albedo[best].y)) best = i;
  double fd_one = central_difference(gs, settings, 2e-2, [best](Scene& s, float h) { s.gaussians->albedo[best].y += h; });
  EXPECT_NEAR(g.gaussian_albedo[best].y, fd_one, 5e-3 * std::fabs(fd_one) + 1e-5);
}

TEST(Gradients, BounceLightFromTheFieldMatchesFiniteDifferences) {
  // With the bounce light taken from the splats' SH (indirect_from_field: the
  // floor's rays that meet the sphere end on its radiance, which no parameter
  // defines), the replay must end each path where the primal did: the albedos'
  // and the environment's gradients match the difference quotient.
  GradientScene gs = make_scene(false);
  IntegratorSettings settings = settings_with(4);
  settings.indirect_from_field = true;
  SceneGradients g = prb(gs.scene, gs.camera, settings, gs.weights);
  expect_albedo_sums_match(gs, settings, g);
  double analytic_floor = 0;
  for (const Vec3& a : g.mesh_base_colour) analytic_floor += a.x;
  double fd_floor = central_difference(gs, settings, 1e-2, [](Scene& s, float h) { s.meshes[0].material.base_colour.x += h; });
  EXPECT_NEAR(analytic_floor, fd_floor, 5e-3 * std::fabs(fd_floor) + 1e-4) << "floor colour (its rays end on the sphere's radiance)";
  // The path-traced loss differs: the sphere's radiance is not what its albedo and the light make of it.
  IntegratorSettings traced = settings;
  traced.indirect_from_field = false;
  EXPECT_GT(std::fabs(loss(gs.scene, gs.camera, settings, gs.weights) - loss(gs.scene, gs.camera, traced, gs.weights)), 1e-3);
}

TEST(Gradients, MeshMaterialMatchesFiniteDifferences) {
  GradientScene gs = make_scene(false);
  IntegratorSettings settings = settings_with(4);
  SceneGradients g = prb(gs.scene, gs.camera, settings, gs.weights);
  for (int c = 0; c < 3; ++c) {
    double fd = central_difference(gs, settings, 1e-2, [c](Scene& s, float h) { s.meshes[0].material.base_colour[c] += h; });
    EXPECT_NEAR(g.mesh_base_colour[0][c], fd, 5e-3 * std::fabs(fd) + 1e-4) << "channel " << c;
  }
  IntegratorSettings v2 = settings;
  v2.brdf = BsdfModel::PrincipledV2;
  SceneGradients g2 = prb(gs.scene, gs.camera, v2, gs.weights);
  for (int c = 0; c < 3; ++c) {
    double fd = central_difference(gs, v2, 1e-2, [c](Scene& s, float h) { s.meshes[0].material.base_colour[c] += h; });
    EXPECT_NEAR(g2.mesh_base_colour[0][c], fd, 5e-3 * std::fabs(fd) + 1e-4) << "v2 channel " << c;
  }
  IntegratorSettings disney = settings;
  disney.brdf = BsdfModel::DisneySimplified;
  SceneGradients gd = prb(gs.scene, gs.camera, disney, gs.weights);
  double fd_m = central_difference(gs, disney, 1e-2, [](Scene& s, float h) { s.meshes[0].material.metallic += h; });
  EXPECT_NEAR(gd.mesh_metallic[0], fd_m, 5e-3 * std::fabs(fd_m) + 1e-4);
}

TEST(Gradients, EnvironmentTexelsMatchFiniteDifferences) {
  GradientScene gs = make_scene(false);
  IntegratorSettings settings = settings_with(4);
  SceneGradients g = prb(gs.scene, gs.camera, settings, gs.weights);
  const Environment& env = *gs.scene.environment.as<Environment>();
  // Directional derivative along "all texels scale by (1 + h)" (sampling tables untouched).
  double analytic = 0;
  for (int i = 0; i < env.width() * env.height(); ++i)
    for (int c = 0; c < 3; ++c) analytic += g.environment[3 * i + c] * env.texels()[3 * i + c];
  double fd = central_difference(gs, settings, 1e-2, [](Scene& s, float h) {
    for (float& t : s.environment.as<Environment>()->texels()) t *= 1.0f + h;
  });
  EXPECT_NEAR(analytic, fd, 5e-3 * std::fabs(fd) + 1e-4);
  EXPECT_GT(std::fabs(fd), 1e-2);
  // The bright texel alone.
  int bright = 2 * env.width() + 3;
  double fd_one = central_difference(gs, settings, 0.5, [bright](Scene& s, float h) {
    s.environment.as<Environment>()->texels()[3 * bright + 2] += h;
  });
  EXPECT_NEAR(g.environment[3 * bright + 2], fd_one, 5e-3 * std::fabs(fd_one) + 1e-5);
}

TEST(Gradients, LightBalanceIsTheDerivativeAlongItsMove) {
  // optim/light_balance.h: dL/d delta for "albedos x e^delta, environment x e^-delta"
  // against central differences of that move, per channel; and the move on the raw
  // parameters does exactly that to the activated values.
  GradientScene gs = make_scene(false);
  IntegratorSettings settings = settings_with(4);
  SceneGradients g = prb(gs.scene, gs.camera, settings, gs.weights);
  ParameterSettings ps;
  Parameters p = make_parameters(gs.scene, ps);
  ASSERT_TRUE(light_balance_applies(p, gs.scene));
  const std::array<double, 3> d = light_balance_derivative(p, gs.scene, g);
  for (int c = 0; c < 3; ++c) {
    double fd = central_difference(gs, settings, 1e-2, [c](Scene& s, float h) {
      for (Vec3& a : s.gaussians->albedo) a[c] *= std::exp(h);
      std::vector<float>& t = s.environment.as<Environment>()->texels();
      for (size_t i = size_t(c); i < t.size(); i += 3) t[i] *= std::exp(-h);
    });
    EXPECT_NEAR(d[c], fd, 5e-3 * std::fabs(fd) + 1e-4) << "channel " << c;
  }
  Scene moved = gs.scene;
  moved.gaussians = std::make_shared<GaussianField>(*gs.scene.gaussians);
  apply_parameters(p, ps, moved);
  const Vec3 a0 = moved.gaussians->albedo[7];
  const float e0 = moved.environment.as<Environment>()->texels()[5];
  light_balance_shift(p, {0.2f, -0.1f, 0.05f});
  apply_parameters(p, ps, moved);
  EXPECT_NEAR(moved.gaussians->albedo[7].x, a0.x * std::exp(0.2f), 1e-5f);
  EXPECT_NEAR(moved.gaussians->albedo[7].y, a0.y * std::exp(-0.1f), 1e-5f);
  EXPECT_NEAR(moved.environment.as<Environment>()->texels()[5], e0 * std::exp(-0.05f), 1e-5f);  // texel 1, blue
}

TEST(Gradients, AlbedoGreyPriorIsItsDerivativeAlongTheBalance) {
  // light_balance.h albedo_chroma_prior: dP/d delta_c of P = 1/2 sum_c (nu_c - mean nu)^2,
  // nu_c = log mean albedo_c, against central differences of the balance's move on the
  // albedos (the light does not enter P); zero for grey albedos.
  GradientScene gs = make_scene(false);
  for (size_t i = 0; i < gs.scene.gaussians->albedo.size(); ++i)
    gs.scene.gaussians->albedo[i] = Vec3(0.6f + 0.01f * float(i % 7), 0.3f, 0.1f + 0.02f * float(i % 3));
  Parameters p = make_parameters(gs.scene, ParameterSettings{});
  const std::array<double, 3> d = albedo_chroma_prior(p, gs.scene);
  auto prior = [&](int c, double h) {
    std::array<double, 3> nu = {0.0, 0.0, 0.0};
    const auto& a = gs.scene.gaussians->albedo;
    for (const Vec3& v : a)
      for (int k = 0; k < 3; ++k) nu[k] += double(v[k]) * (k == c ? std::exp(h) : 1.0);
    for (double& n : nu) n = std::log(n / double(a.size()));
    const double m = (nu[0] + nu[1] + nu[2]) / 3.0;
    return 0.5 * ((nu[0] - m) * (nu[0] - m) + (nu[1] - m) * (nu[1] - m) + (nu[2] - m) * (nu[2] - m));
  };
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(d[c], (prior(c, 1e-4) - prior(c, -1e-4)) / 2e-4, 1e-5) << "channel " << c;
  for (Vec3& a : gs.scene.gaussians->albedo) a = Vec3(0.4f, 0.4f, 0.4f);
  for (double v : albedo_chroma_prior(p, gs.scene)) EXPECT_NEAR(v, 0.0, 1e-9);
}

TEST(Gradients, LightBalanceCountsOnlyTheRiseAnAlbedoCanTake) {
  // An albedo pinned at the top of its range cannot rise with the balance's step, so
  // only the light's side of the move counts for it (else the balance runs away:
  // every step darkens the light and moves no albedo); albedos with room to rise
  // keep the plain derivative.
  GradientScene gs = make_scene(false);
  SceneGradients g = prb(gs.scene, gs.camera, settings_with(4), gs.weights);
  for (Vec3& a : gs.scene.gaussians->albedo) a = Vec3(0.99995f, 0.5f, 0.2f);
  Parameters p = make_parameters(gs.scene, ParameterSettings{});
  const std::array<double, 3> plain = light_balance_derivative(p, gs.scene, g);
  const std::array<double, 3> step = light_balance_derivative(p, gs.scene, g, 0.1f);
  const std::vector<float>& t = gs.scene.environment.as<Environment>()->texels();
  double light_side = 0.0, albedo_side = 0.0;
  for (size_t i = 0; i < t.size(); i += 3) light_side -= double(t[i]) * double(g.environment[i]);
  for (size_t i = 0; i < gs.scene.gaussians->size(); ++i) albedo_side += 0.99995 * double(g.gaussian_albedo[i][0]);
  ASSERT_GT(std::fabs(albedo_side), 1e-3 * std::fabs(light_side));
  EXPECT_NEAR(plain[0], light_side + albedo_side, 1e-9 + 1e-6 * std::fabs(plain[0]));
  EXPECT_NEAR(step[0], light_side, 1e-9 + 1e-6 * std::fabs(light_side));  // pinned: the light alone
  EXPECT_EQ(step[1], plain[1]);                                           // room to rise: unchanged
  EXPECT_EQ(step[2], plain[2]);
}

TEST(Gradients, RoughnessAndMetallicMatchFiniteDifferencesInExpectation) {
  // Roughness moves the sampled directions, so a finite difference with common
  // random numbers jumps whenever a direction crosses a shadow or light edge: its
  // noise, not a bias, dominates. Paired test over independent seeds: the mean of
  // (PRB - FD) must be within 3 standard errors of 0 (and within 3% of the
  // gradient when that is looser), and the test must have the power to see a 10% bias.
  GradientScene gs = make_scene(false);
  for (float& w : gs.weights.pixels) w = 1.0f;  // loss = image sum: a strong, one-signed signal
  struct Case {
    const char* name;
    std::function<double(const SceneGradients&)> prb;
    std::function<void(Scene&, float)> apply;
  };
  std::vector<Case> cases = {
      {"gaussian roughness",
       [](const SceneGradients& g) {
         double s = 0;
         for (float r : g.gaussian_roughness) s += r;
         return s;
       },
       [](Scene& s, float h) {
         for (float& r : s.gaussians->roughness) r += h;
       }},
      {"mesh roughness", [](const SceneGradients& g) { return double(g.mesh_roughness[0]); },
       [](Scene& s, float h) { s.meshes[0].material.roughness += h; }},
      {"gaussian metallic (Principled)",
       [](const SceneGradients& g) {
         double s = 0;
         for (float m : g.gaussian_metallic) s += m;
         return s;
       },
       [](Scene& s, float h) {
         for (float& m : s.gaussians->metallic) m += h;
       }},
      {"mesh metallic (Principled)", [](const SceneGradients& g) { return double(g.mesh_metallic[0]); },
       [](Scene& s, float h) { s.meshes[0].material.metallic += h; }},
  };
  const int seeds = 12;
  for (const Case& c : cases) {
    std::vector<double> diff, fds;
    for (int k = 0; k < seeds; ++k) {
      IntegratorSettings settings = settings_with(256);
      settings.seed = 100 + k;
      double analytic = c.prb(prb(gs.scene, gs.camera, settings, gs.weights));
      double fd = central_difference(gs, settings, 0.1, c.apply);
      diff.push_back(analytic - fd);
      fds.push_back(fd);
    }
    double mean_d = 0, mean_fd = 0, var = 0;
    for (int k = 0; k < seeds; ++k) mean_d += diff[k] / seeds, mean_fd += fds[k] / seeds;
    for (double d : diff) var += (d - mean_d) * (d - mean_d) / (seeds - 1);
    double se = std::sqrt(var / seeds);
    EXPECT_LT(se, 0.1 * std::fabs(mean_fd) / 3.0) << c.name << ": too noisy to detect a 10% bias";
    EXPECT_LE(std::fabs(mean_d), std::max(3.0 * se, 0.03 * std::fabs(mean_fd)))
        << c.name << ": mean PRB - FD " << mean_d << ", standard error " << se << ", FD " << mean_fd;
  }
}

TEST(Gradients, SgAmplitudesMatchFiniteDifferencesInExpectation) {
  GradientScene gs = make_scene(true);
  IntegratorSettings settings = settings_with(256);
  SceneGradients g = prb(gs.scene, gs.camera, settings, gs.weights);
  double analytic = 0;
  for (float d : g.environment) analytic += d;
  double fd = central_difference(gs, settings, 0.05, [](Scene& s, float h) {
    SgEnvironment& sg = *s.environment.as<SgEnvironment>();
    for (Vec3& x : sg.raw()) x += Vec3(h);
    sg.update();
  });
  EXPECT_NEAR(analytic, fd, 0.05 * std::fabs(fd)) << "analytic " << analytic << " fd " << fd;
  EXPECT_GT(std::fabs(fd), 1e-2);
}

TEST(Gradients, StoredSampleRadianceGivesTheSameGradients) {
  GradientScene gs = make_scene(false);
  IntegratorSettings settings = settings_with(3);
  PathTracer tracer(gs.scene);
  ReplayCache stored = ReplayCache::radiance_only();
  render_path(tracer, gs.camera, settings, {}, nullptr, &stored);
  SceneGradients a = SceneGradients::zeros_like(gs.scene), b = a;
  render_path_backward(tracer, gs.camera, settings, gs.weights, a, {}, &stored);
  render_path_backward(tracer, gs.camera, settings, gs.weights, b);
  for (size_t i = 0; i < a.gaussian_albedo.size(); ++i) ASSERT_EQ(a.gaussian_albedo[i].x, b.gaussian_albedo[i].x);
  for (size_t i = 2; i < a.environment.size(); i += 3) ASSERT_EQ(a.environment[i], b.environment[i]);
}

TEST(Gradients, DeterministicForAFixedSeed) {
  GradientScene gs = make_scene(false);
  IntegratorSettings settings = settings_with(2);
  SceneGradients a = prb(gs.scene, gs.camera, settings, gs.weights);
  SceneGradients b = prb(gs.scene, gs.camera, settings, gs.weights);
  for (size_t i = 0; i < a.gaussian_albedo.size(); ++i) {
    ASSERT_EQ(a.gaussian_albedo[i].x, b.gaussian_albedo[i].x);
    ASSERT_EQ(a.gaussian_roughness[i], b.gaussian_roughness[i]);
  }
  for (size_t i = 1; i < a.environment.size(); i += 3) ASSERT_EQ(a.environment[i], b.environment[i]);
}

