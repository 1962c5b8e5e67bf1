// What a real capture's seen background texels learn (ParameterSettings::env_init_seen_coarse,
// `ptir optimize --env-seen coarse`): their fine level is held at the photos' radiance, their change
// comes from the coarse level only, and the unseen texels learn both levels. Checked against central
// differences of a linear objective of the texels, so the held texels' gradient still reaching the
// coarse level (the point of the mode) and not reaching the fine one are both measured.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "ptir/io/image.h"
#include "ptir/lights/environment.h"
#include "ptir/optim/parameters.h"
#include "optimizer_fixture.h"

using namespace ptir;

namespace {

constexpr int kW = 8, kH = 4;

// An 8x4 map whose left half is seen (alpha 1) and right half not.
std::string seen_map() {
  const std::filesystem::path dir = test::fresh_dir("env_seen");
  Image map(kW, kH, {"R", "G", "B", "A"});
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      float* p = &map.pixels[4 * (size_t(y) * kW + x)];
      p[0] = 0.2f + 0.05f * float(x);
      p[1] = 0.3f + 0.04f * float(y);
      p[2] = 0.25f;
      p[3] = x < kW / 2 ? 1.0f : 0.0f;
    }
  const std::string path = (dir / "seen.exr").string();
  write_image(path, map);
  return path;
}

}  // namespace

TEST(EnvSeen, HeldFineTexelsStillMoveTheCoarseLevel) {
  Scene scene;
  scene.gaussians = std::make_shared<GaussianField>(test::truth_field(4));
  ParameterSettings ps;
  ps.env = EnvMode::LatLong;
  ps.env_init_path = seen_map();
  ps.env_coarse_width = 4;  // a 4x2 coarse level, bilinear onto the 8x4 texels
  ps.env_init_seen_coarse = true;
  install_environment(scene, ps);
  Parameters p = make_parameters(scene, ps);
  ParameterGroup* fine = p.find(ParamKind::Environment);
  ParameterGroup* coarse = p.find(ParamKind::EnvironmentCoarse);
  ASSERT_TRUE(fine && coarse);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (float& x : coarse->raw) x = 0.3f * u(rng);
  SceneGradients gr = SceneGradients::zeros_like(scene);
  for (float& x : gr.environment) x = u(rng);
  // The objective: the adjoint's dot product with the texels the scene ends up with.
  auto objective = [&](const Parameters& q) {
    apply_parameters(q, ps, scene);
    const Environment* env = scene.environment.as<Environment>();
    double s = 0.0;
    for (int i = 0; i < kW * kH; ++i) {
      const Vec3 t = env->texel(i % kW, i / kW);
      s += gr.environment[3 * i] * t[0] + gr.environment[3 * i + 1] * t[1] + gr.environment[3 * i + 2] * t[2];
    }
    return s;
  };
  apply_parameters(p, ps, scene);
  const std::vector<std::vector<float>> d = raw_gradients(p, gr, scene);
  const size_t fi = size_t(fine - p.groups.data()), ci = size_t(coarse - p.groups.data());
  // The fine level: no step where the photos saw the light, the exact gradient elsewhere.
  for (size_t k = 0; k < fine->raw.size(); ++k) {
    const int x = int(k / 3) % kW;
    Parameters a = p, b = p;
    a.groups[fi].raw[k] += 1e-2f;
    b.groups[fi].raw[k] -= 1e-2f;
    const double fd = (objective(a) - objective(b)) / 2e-2;
    if (x < kW / 2) {
      EXPECT_EQ(d[fi][k], 0.0f) << "seen texel " << k;
    } else {
      EXPECT_NEAR(d[fi][k], fd, 2e-3 * std::max(1.0, std::fabs(fd))) << "unseen texel " << k;
      EXPECT_GT(std::fabs(fd), 1e-4) << "unseen texel " << k;
    }
  }
  // The coarse level: the exact gradient over every texel it reaches, the seen ones included.
  for (size_t k = 0; k < coarse->raw.size(); ++k) {
    Parameters a = p, b = p;
    a.groups[ci].raw[k] += 1e-2f;
    b.groups[ci].raw[k] -= 1e-2f;
    const double fd = (objective(a) - objective(b)) / 2e-2;
    EXPECT_NEAR(d[ci][k], fd, 2e-3 * std::max(1.0, std::fabs(fd))) << "coarse " << k;
  }
  // The seen half moves with the coarse level (held fixed, as --fix-env-seen does, it would not).
  Parameters moved = p;
  for (float& x : moved.groups[ci].raw) x += 0.5f;
  apply_parameters(moved, ps, scene);
  const float after = scene.environment.as<Environment>()->texel(0, 0)[0];
  apply_parameters(p, ps, scene);
  const float before = scene.environment.as<Environment>()->texel(0, 0)[0];
  EXPECT_NEAR(after / before, std::exp(0.5f), 1e-3f);
}
