// The decorrelated adjoint (OptimizerSettings::decorrelate_adjoint): with one set
// of samples for the loss and its replay, the step follows the gradient of the
// expected *noisy* loss, whose variance term flattens the light over a long run;
// with two independent halves it does not.
#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "optimizer_fixture.h"
#include "ptir/io/image.h"
#include "ptir/optim/optimizer.h"
#include "ptir/optim/parameters.h"

namespace fs = std::filesystem;
using namespace ptir;

namespace {

// The fixture's true sky as an EXR (the optimiser's starting environment).
std::string true_sky_file() {
  static const std::string path = [] {
    const fs::path dir = test::fresh_dir("decorrelated_adjoint");
    write_image((dir / "sky.exr").string(), test::sky().to_latlong(16, 8));
    return (dir / "sky.exr").string();
  }();
  return path;
}

// An optimiser at the truth: the fixture's sky (texels only, no coarse level) and
// the true albedos and roughnesses.
std::unique_ptr<Optimizer> at_truth(OptimizerSettings s) {
  const test::OptimizerFixture& fx = test::fixture();
  s.params.env_init_path = true_sky_file();
  s.params.env_coarse_width = 0;
  auto opt = std::make_unique<Optimizer>(test::input_scene(fx.n), fx.data, s);
  Parameters p = opt->parameters();
  const GaussianField f = test::truth_field(fx.n);
  ParameterGroup* alb = p.find(ParamKind::GaussianAlbedo);
  ParameterGroup* rough = p.find(ParamKind::GaussianRoughness);
  for (size_t i = 0; i < fx.n; ++i) {
    for (int c = 0; c < 3; ++c) alb->raw[3 * i + size_t(c)] = logit_clamped(f.albedo[i][c]);
    rough->raw[i] = roughness_to_raw(f.roughness[i]);
  }
  opt->set_parameters(p);
  return opt;
}

}  // namespace

// The expected gradient, in the setting where the theory is exact: an L2 image
// loss (Huber's function with a knee above every residual, linear values, no blur
// or SSIM). Decorrelated, E[L'(I_A)] E[dI_B] = L'(E I) dE I: unbiased; with the
// same samples the covariance of I and dI adds the gradient of the render's
// variance. Mean over many seeds at 2 spp against a 1024-spp reference.
TEST(DecorrelatedAdjoint, IsUnbiasedForAnL2Loss) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  const test::OptimizerFixture& fx = test::fixture();
  OptimizerSettings s = test::small_settings();
  s.views_per_iteration = int(fx.data->size());  // every view in every evaluation
  s.srgb_loss = false;
  s.loss.lambda_ssim = 0.0f;
  s.loss.binomial_filter = false;
  s.loss.huber_delta = 1e3f;
  s.lambda_tv = 0.0f;
  // The summed environment gradient (d/d log of a uniform scale), the hot texel's,
  // and the summed Gaussian roughness and albedo gradients.
  constexpr int kStats = 4;
  const char* names[kStats] = {"all texels", "hot texel", "roughness", "albedo"};
  auto grads = [](const Optimizer& opt) {
    const std::vector<float>& g = opt.gradients().environment;
    const std::vector<float>& t = opt.scene().environment.as<Environment>()->texels();
    size_t hot = 0;
    double total = 0.0;
    for (size_t i = 0; i < g.size(); ++i) {
      total += double(g[i]) * t[i];
      if (t[i] > t[hot]) hot = i;
    }
    double rough = 0.0, alb = 0.0;
    for (float r : opt.gradients().gaussian_roughness) rough += r;
    for (const Vec3& a : opt.gradients().gaussian_albedo) alb += double(a.x) + a.y + a.z;
    return std::array<double, kStats>{total, double(g[hot]) * t[hot], rough, alb};
  };
  s.integrator.spp = 1024;
  std::unique_ptr<Optimizer> ref_opt = at_truth(s);
  ref_opt->evaluate(0, true);
  const std::array<double, kStats> ref = grads(*ref_opt);
  const int K = 64;
  s.integrator.spp = 2;
  for (bool decorrelate : {false, true}) {
    s.decorrelate_adjoint = decorrelate;
    std::unique_ptr<Optimizer> opt = at_truth(s);
    std::array<double, kStats> mean{}, sq{};
    for (int k = 0; k < K; ++k) {
      opt->evaluate(k, true);
      const std::array<double, kStats> g = grads(*opt);
      for (int j = 0; j < kStats; ++j) {
        mean[j] += g[j] / K;
        sq[j] += g[j] * g[j] / K;
      }
    }
    for (int j = 0; j < kStats; ++j) {
      const double se = std::sqrt(std::max(0.0, sq[j] - mean[j] * mean[j]) / (K - 1));
      const double z = (mean[j] - ref[j]) / se;
      std::printf("%s, %s: mean %.4g (standard error %.3g), reference %.4g: %.1f standard errors off\n",
                  decorrelate ? "decorrelated" : "same samples", names[j], mean[j], se, ref[j], z);
      // Measured (all texels / hot texel / roughness / albedo): decorrelated
      // 0.7 / -0.8 / 0.5 / 0.7 standard errors; same samples +64 / +27 / +34 / +71
      // (positive: the step darkens the light and the albedo and sharpens the
      // lobes, whatever lowers the render's variance).
      if (decorrelate) EXPECT_LT(std::fabs(z), 4.0) << names[j];
      else EXPECT_GT(z, 10.0) << names[j];
    }
  }
}
