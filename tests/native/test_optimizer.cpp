// The inversion loop: activations and their chain rule, Adam, checkpoints, the
// whole objective's gradient against finite differences, exact resume,
// cancellation, view/crop selection, and that the loss goes down.
#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <set>
#include <sstream>

#include "ptir/core/error.h"
#include "ptir/scene/dataset.h"
#include "ptir/optim/adam.h"
#include "ptir/optim/checkpoint.h"
#include "ptir/optim/optimizer.h"
#include "ptir/optim/parameters.h"
#include "ptir/render/aov.h"
#include "ptir/render/material_maps.h"
#include "ptir/render/render_path.h"
#include "ptir/scene/gaussian_ply.h"
#include "expect_error.h"
#include "optimizer_fixture.h"
#include "test_scenes.h"

namespace fs = std::filesystem;
using namespace ptir;

namespace {

using test::fixture;
using test::fresh_dir;
using test::input_scene;
using test::small_settings;
using test::truth_field;

bool same_state(const Optimizer& a, const Optimizer& b) {
  const Parameters &pa = a.parameters(), &pb = b.parameters();
  if (pa.groups.size() != pb.groups.size()) return false;
  for (size_t i = 0; i < pa.groups.size(); ++i) {
    if (pa.groups[i].raw != pb.groups[i].raw) return false;
    if (a.adam()[i].m != b.adam()[i].m || a.adam()[i].v != b.adam()[i].v || a.adam()[i].t != b.adam()[i].t) return false;
  }
  return a.iteration() == b.iteration();
}

// A run of `steps` iterations saved to `ckpt`, and a fresh optimiser restored from it.
std::unique_ptr<Optimizer> resumed_from(const test::OptimizerFixture& fx, const OptimizerSettings& s, int steps,
                                        const std::string& ckpt) {
  {
    Optimizer first(input_scene(fx.n), fx.data, s);
    for (int i = 0; i < steps; ++i) first.step();
    first.save_checkpoint(ckpt);
  }
  auto resumed = std::make_unique<Optimizer>(input_scene(fx.n), fx.data, s);
  resumed->load_checkpoint(ckpt);
  return resumed;
}

}  // namespace

TEST(Parameters, ActivationsAndTheirInverses) {
  EXPECT_NEAR(roughness_from_raw(roughness_to_raw(0.6f)), 0.6f, 1e-6f);
  EXPECT_NEAR(roughness_from_raw(-40.0f), kRoughnessMin, 1e-6f);
  EXPECT_NEAR(roughness_from_raw(40.0f), kRoughnessMin + kRoughnessRange, 1e-6f);
  EXPECT_NEAR(sigmoid(logit_clamped(0.3f)), 0.3f, 1e-6f);
  EXPECT_TRUE(std::isfinite(logit_clamped(0.0f)));
  EXPECT_TRUE(std::isfinite(roughness_to_raw(0.05f)));  // below the range: clamped
}

TEST(Parameters, ChainRuleMatchesFiniteDifferencesOfTheActivations) {
  Scene scene;
  scene.gaussians = std::make_shared<GaussianField>(truth_field(20));
  scene.meshes.push_back(test::quad_z(-2.0f, 3.0f));
  // The lat-long map twice: texels only, and with a 4x2 coarse level (env_pyramid.h).
  for (auto [mode, coarse] : {std::pair{EnvMode::LatLong, 0}, std::pair{EnvMode::LatLong, 4}, std::pair{EnvMode::SG, 0},
                              std::pair{EnvMode::Constant, 0}}) {
    ParameterSettings ps;
    ps.optimize_metallic = true;
    ps.optimize_meshes = true;
    ps.env = mode;
    ps.env_coarse_width = coarse;
    ps.env_width = 8;
    ps.env_height = 4;
    install_environment(scene, ps);
    Parameters p = make_parameters(scene, ps);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-2.0f, 2.0f);
    for (ParameterGroup& g : p.groups)
      for (float& x : g.raw) x = u(rng);
    // Random adjoints w.r.t. activated values: the objective is their dot product.
    SceneGradients gr = SceneGradients::zeros_like(scene);
    for (auto* v : {&gr.gaussian_albedo, &gr.mesh_base_colour})
      for (Vec3& x : *v) x = Vec3(u(rng), u(rng), u(rng));
    for (auto* v : {&gr.gaussian_roughness, &gr.gaussian_metallic, &gr.mesh_roughness, &gr.mesh_metallic, &gr.environment})
      for (float& x : *v) x = u(rng);
    auto objective = [&](const Parameters& q) {
      apply_parameters(q, ps, scene);
      const GaussianField& f = *scene.gaussians;
      double s = 0;
      for (size_t i = 0; i < f.size(); ++i)
        s += dot(gr.gaussian_albedo[i], f.albedo[i]) + gr.gaussian_roughness[i] * f.roughness[i] +
             gr.gaussian_metallic[i] * f.metallic[i];
      for (size_t i = 0; i < scene.meshes.size(); ++i)
        s += dot(gr.mesh_base_colour[i], scene.meshes[i].material.base_colour) +
             gr.mesh_roughness[i] * scene.meshes[i].material.roughness + gr.mesh_metallic[i] * scene.meshes[i].material.metallic;
      if (const Environment* env = scene.environment.as<Environment>())
        for (size_t i = 0; i < gr.environment.size() / 3; ++i)
          s += dot(Vec3(gr.environment[3 * i], gr.environment[3 * i + 1], gr.environment[3 * i + 2]),
                   env->texel(int(i) % 8, int(i) / 8));
      // SG: the adjoint is already w.r.t. raw (identity chain).
      if (const SgEnvironment* sg = scene.environment.as<SgEnvironment>())
        for (size_t i = 0; i < gr.environment.size() / 3; ++i)
          s += dot(Vec3(gr.environment[3 * i], gr.environment[3 * i + 1], gr.environment[3 * i + 2]), sg->raw()[i]);
      // Constant: the adjoint is w.r.t. the colour.
      if (const ConstantEnvironment* k = scene.environment.as<ConstantEnvironment>())
        s += dot(Vec3(gr.environment[0], gr.environment[1], gr.environment[2]), k->colour());
      return s;
    };
    std::vector<std::vector<float>> d = raw_gradients(p, gr, scene);
    ASSERT_EQ(d.size(), p.groups.size());
    for (size_t gi = 0; gi < p.groups.size(); ++gi) {
      for (size_t k = 0; k < p.groups[gi].raw.size(); k += 7) {
        Parameters a = p, b = p;
        const float h = 1e-2f;
        a.groups[gi].raw[k] += h;
        b.groups[gi].raw[k] -= h;
        double fd = (objective(a) - objective(b)) / (2.0 * h);
        EXPECT_NEAR(d[gi][k], fd, 2e-3 * std::max(1.0, std::fabs(fd)))
            << param_kind_name(p.groups[gi].kind) << "[" << k << "]";
      }
    }
  }
}

TEST(Adam, MatchesTheReferenceFormula) {
  Adam adam(2, 0.1f);
  std::vector<float> x = {1.0f, -2.0f};
  double m[2] = {0, 0}, v[2] = {0, 0}, xr[2] = {1.0, -2.0};
  for (int t = 1; t <= 5; ++t) {
    std::vector<float> g = {0.5f * float(t), t % 2 ? -1e-3f : 2e-3f};
    adam.step(x, g);
    for (int i = 0; i < 2; ++i) {
      m[i] = 0.9 * m[i] + 0.1 * g[i];
      v[i] = 0.999 * v[i] + 0.001 * double(g[i]) * g[i];
      xr[i] -= 0.1 * (m[i] / (1 - std::pow(0.9, t))) / (std::sqrt(v[i] / (1 - std::pow(0.999, t))) + 1e-15);
    }
  }
  EXPECT_EQ(adam.t, 5u);
  EXPECT_NEAR(x[0], xr[0], 1e-5);
  EXPECT_NEAR(x[1], xr[1], 1e-5);
  std::vector<float> bad(3);
  EXPECT_THROW(adam.step(bad, bad), Error);
}

TEST(Checkpoint, RoundTripAndCorruption) {
  fs::path d = fresh_dir("ckpt");
  Checkpoint c;
  c.iteration = 12;
  c.fingerprint = {{"spp", "4"}, {"gaussians", "10"}};
  c.groups.push_back({ParamKind::GaussianAlbedo, 0.035f, 12, {1, 2, 3}, {0.1f, 0.2f, 0.3f}, {1e-3f, 2e-3f, 3e-3f}});
  c.normals = {Vec3(0, 0, 1)};
  IterationLog l;
  l.iteration = 12;
  l.loss = 0.25;
  l.views = "a+b";
  c.log = {l};
  c.averaged = 3;
  c.average_begin = 9;
  c.average_sum = {{4.0, 5.5, -1.25}};
  const std::string path = (d / "c.bin").string();
  write_checkpoint(path, c);
  Checkpoint r = read_checkpoint(path);
  EXPECT_EQ(r.averaged, 3u);
  EXPECT_EQ(r.average_begin, 9);
  EXPECT_EQ(r.average_sum, c.average_sum);
  EXPECT_EQ(r.iteration, 12u);
  EXPECT_EQ(r.fingerprint, c.fingerprint);
  ASSERT_EQ(r.groups.size(), 1u);
  EXPECT_EQ(r.groups[0].raw, c.groups[0].raw);
  EXPECT_EQ(r.groups[0].v, c.groups[0].v);
  EXPECT_EQ(r.groups[0].adam_t, 12u);
  EXPECT_EQ(r.log[0].views, "a+b");
  EXPECT_EQ(r.log[0].loss, 0.25);
  for (const auto& entry : fs::directory_iterator(d)) EXPECT_EQ(entry.path().filename(), "c.bin");  // no temp file left

  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    bytes = ss.str();
  }
  std::ofstream(path, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  EXPECT_THROW(read_checkpoint(path), Error);
  std::string flipped = bytes;
  flipped[40] ^= 1;
  std::ofstream(path, std::ios::binary) << flipped;
  try {
    read_checkpoint(path);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("corrupt"), std::string::npos) << e.what();
  }
  try {
    check_fingerprint(path, {{"spp", "4"}, {"gaussians", "10"}}, {{"spp", "8"}, {"gaussians", "10"}});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("spp: checkpoint 4, now 8"), std::string::npos) << e.what();
  }
}

// Checkpoints written before the lost options were removed (docs/inversion.md):
// at those options' defaults they resume, else they are refused naming the option
// and the commit whose ptir still reads them.
TEST(Optimizer, CheckpointsOfRemovedOptionsResumeAtTheirDefaultsOnly) {
  const test::OptimizerFixture& fx = fixture();
  Optimizer opt(input_scene(fx.n), fx.data, small_settings());
  Fingerprint old;
  for (auto kv : opt.fingerprint()) {
    old.push_back(kv);
    if (kv.first == "lr_schedule") old.push_back({"env_adam", "texel"});
    if (kv.first == "adjoint") old.push_back({"huber", "0"});
    if (kv.first == "warmup") old.push_back({"environment prior", "smooth 0 chroma 0 fine warmup 0"});
  }
  Fingerprint at_defaults = old;
  retire_fingerprint_entries("old.bin", at_defaults);
  EXPECT_EQ(at_defaults, opt.fingerprint());
  const auto with = [&](const std::string& key, const std::string& value) {
    Fingerprint f = old;
    bool found = false;
    for (auto& kv : f)
      if (kv.first == key) kv.second = value, found = true;
    if (!found) f.push_back({key, value});
    return f;
  };
  const std::pair<Fingerprint, std::string> refused[] = {
      {with("light solve", "0.5 spp 8 ridge 0.01 smooth 30 range 0.1 10 grid 16"), "--light-solve"},
      {with("env_adam", "shared"), "--env-adam shared"},
      {with("huber", "0.05"), "--huber-delta 0.05"},
      {with("environment prior", "smooth 0.001 chroma 0 fine warmup 0"), "--lambda-env-smooth"},
      {with("loss", "0 blur target srgb-tangent"), "--loss-space srgb-tangent"},
      {with("loss", "0.2 blur target srgb-blur-first cross ssim"), "--ssim-cross"},
  };
  for (const auto& [fp, option] : refused) {
    Fingerprint f = fp;
    test::expect_error([&] { retire_fingerprint_entries("old.bin", f); }, "old.bin",
                       {option, "removed", kLastCommitWithRetiredOptions});
  }
  // An iterate average (--average-from) is in the checkpoint's body, not its fingerprint.
  Checkpoint averaged = opt.checkpoint();
  averaged.averaged = 2;
  test::expect_error([&] { opt.restore(averaged, "old.bin"); }, "old.bin",
                     {"--average-from", "removed", kLastCommitWithRetiredOptions});
  opt.restore(opt.checkpoint(), "now.bin");  // today's own checkpoint resumes
}

TEST(Optimizer, ViewsCoverEveryViewOncePerEpochAndCropsStayInside) {
  const test::OptimizerFixture& fx = fixture();
  OptimizerSettings s = small_settings();
  s.views_per_iteration = 3;
  s.crop_size = 10;
  Optimizer opt(input_scene(fx.n), fx.data, s);
  const size_t N = fx.data->size();
  std::vector<size_t> seq;
  for (int it = 0; it < 8; ++it)
    for (const auto& p : opt.pick_views(it)) {
      seq.push_back(p.view);
      EXPECT_EQ(p.w, 10);
      EXPECT_EQ(p.h, 10);
      EXPECT_GE(p.x0, 0);
      EXPECT_GE(p.y0, 0);
      EXPECT_LE(p.x0 + p.w, fx.data->width);
      EXPECT_LE(p.y0 + p.h, fx.data->height);
    }
  for (size_t e = 0; e + N <= seq.size(); e += N) {
    std::set<size_t> epoch(seq.begin() + long(e), seq.begin() + long(e + N));
    EXPECT_EQ(epoch.size(), N) << "epoch " << e / N;
  }
  // Keyed: asking again gives the same picks.
  auto a = opt.pick_views(5), b = opt.pick_views(5);
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].view, b[i].view);
    EXPECT_EQ(a[i].x0, b[i].x0);
  }
}

// The gradient of the whole objective (image loss through the sRGB curve and the
// binomial filter, PRB through the path tracer, TV through the AOV adjoint,
// activations) against central differences of the same objective with the same
// random numbers. Albedo: the paths do not depend on it, so the two agree up to
// the L1 kinks. Environment: a uniform scale of every texel leaves the sampling
// distribution unchanged, so again the same paths.
TEST(Optimizer, ObjectiveGradientMatchesFiniteDifferences) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  const test::OptimizerFixture& fx = fixture();
  OptimizerSettings s = small_settings();
  s.integrator.spp = 4;
  s.views_per_iteration = 2;
  s.crop_size = 20;
  s.decorrelate_adjoint = false;  // one set of samples: the gradient of the objective evaluate() returns
  Optimizer opt(input_scene(fx.n), fx.data, s);
  // Move away from the uniform start so that TV has something to act on.
  Parameters p0 = opt.parameters();
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-0.5f, 0.5f);
  for (ParameterGroup& g : p0.groups)
    for (float& x : g.raw) x += u(rng);
  opt.set_parameters(p0);
  const int it = 3;
  IterationLog base = opt.evaluate(it, true);
  EXPECT_GT(base.image, 0.0);
  EXPECT_GT(base.tv, 0.0);
  std::vector<std::vector<float>> g = raw_gradients(opt.parameters(), opt.gradients(), opt.scene());

  auto directional = [&](ParamKind kind, auto&& select) {
    size_t gi = 0;
    while (p0.groups[gi].kind != kind) ++gi;
    double analytic = 0;
    for (size_t k = 0; k < p0.groups[gi].raw.size(); ++k)
      if (select(k)) analytic += g[gi][k];
    // Small: few L1 kinks are crossed (at 0.02 they cost ~10% on a small term; with the
    // Blackman-Harris sample offsets, 0.0025 crosses one on the bottom albedo: FD 3.3e-5 vs 0;
    // with the Principled BSDF 0.001 still crosses one there: 2.3 % off, 0.0004 agrees).
    const float h = 0.0004f;
    Parameters a = p0, b = p0;
    for (size_t k = 0; k < p0.groups[gi].raw.size(); ++k)
      if (select(k)) {
        a.groups[gi].raw[k] += h;
        b.groups[gi].raw[k] -= h;
      }
    opt.set_parameters(a);
    double la = opt.evaluate(it, false).loss;
    opt.set_parameters(b);
    double lb = opt.evaluate(it, false).loss;
    opt.set_parameters(p0);
    return std::make_pair(analytic, (la - lb) / (2.0 * h));
  };
  const GaussianField& f = *opt.scene().gaussians;
  for (int c = 0; c < 3; ++c) {
    auto [an, fd] = directional(ParamKind::GaussianAlbedo, [&](size_t k) { return int(k % 3) == c && f.position[k / 3].z > 0; });
    EXPECT_NEAR(an, fd, 0.01 * std::fabs(fd) + 5e-6) << "albedo channel " << c << " (top)";
    auto [an2, fd2] = directional(ParamKind::GaussianAlbedo, [&](size_t k) { return int(k % 3) == c && f.position[k / 3].z <= 0; });
    EXPECT_NEAR(an2, fd2, 0.01 * std::fabs(fd2) + 5e-6) << "albedo channel " << c << " (bottom)";
  }
  auto [an, fd] = directional(ParamKind::Environment, [](size_t) { return true; });
  EXPECT_NEAR(an, fd, 0.01 * std::fabs(fd) + 5e-6) << "environment scale";

  // Single texels (perturbed without rebuilding the sampling tables, so the paths stay the same).
  opt.evaluate(it, true);
  const SceneGradients gr = opt.gradients();
  std::vector<std::pair<float, size_t>> order;
  for (size_t i = 0; i < gr.environment.size() / 3; ++i) order.push_back({-std::fabs(gr.environment[3 * i + 1]), i});
  std::sort(order.begin(), order.end());
  auto& tex = opt.scene().environment.as<Environment>()->texels();
  for (int k = 0; k < 3; ++k) {
    const size_t i = order[size_t(k) * 4].second;
    const float h = 0.01f, old = tex[3 * i + 1];
    tex[3 * i + 1] = old + h;
    double la = opt.evaluate(it, false).loss;
    tex[3 * i + 1] = old - h;
    double lb = opt.evaluate(it, false).loss;
    tex[3 * i + 1] = old;
    double fd1 = (la - lb) / (2.0 * h);
    EXPECT_NEAR(gr.environment[3 * i + 1], fd1, 0.01 * std::fabs(fd1) + 1e-6) << "texel " << i;
  }
}

TEST(Optimizer, ResumeIsBitIdenticalForTheOtherEnvironmentModels) {
  // SG and constant environments: a resumed run sets the raw parameters on a fresh
  // model fewer times than an uninterrupted one; the result must not depend on that
  // (the SG axes once drifted by an ulp per update).
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  const test::OptimizerFixture& fx = fixture();
  // Also the lat-long map with a coarse level and the learning-rate decay (their
  // state is the iteration count and the Adam groups).
  for (EnvMode mode : {EnvMode::SG, EnvMode::Constant, EnvMode::LatLong}) {
    OptimizerSettings s = small_settings();
    s.params.env = mode;
    if (mode == EnvMode::LatLong) {
      s.params.env_coarse_width = 4;
      s.lr_final = 0.5f;
      s.lr_decay_start = 0.0f;
    }
    const fs::path d = fresh_dir(std::string("resume_") + env_mode_name(mode));
    const std::string ckpt = (d / "checkpoint.bin").string();
    Optimizer straight(input_scene(fx.n), fx.data, s);
    for (int i = 0; i < 4; ++i) straight.step();
    const auto held = resumed_from(fx, s, 2, ckpt);
    Optimizer& resumed = *held;
    for (int i = 0; i < 2; ++i) resumed.step();
    EXPECT_TRUE(same_state(straight, resumed)) << env_mode_name(mode);
    EXPECT_EQ(straight.environment_image().pixels, resumed.environment_image().pixels) << env_mode_name(mode);
    const GaussianField &a = *straight.scene().gaussians, &b = *resumed.scene().gaussians;
    for (size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a.albedo[i].y, b.albedo[i].y) << env_mode_name(mode);
  }
}

TEST(Optimizer, ResumeIsBitIdenticalToAnUninterruptedRun) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  const test::OptimizerFixture& fx = fixture();
  OptimizerSettings s = small_settings();
  s.views_per_iteration = 2;
  s.crop_size = 16;
  const fs::path d = fresh_dir("resume");
  const std::string ckpt = (d / "checkpoint.bin").string();

  Optimizer straight(input_scene(fx.n), fx.data, s);
  for (int i = 0; i < 6; ++i) straight.step();

  const auto held = resumed_from(fx, s, 3, ckpt);
  Optimizer& resumed = *held;
  EXPECT_EQ(resumed.iteration(), 3);
  for (int i = 0; i < 3; ++i) resumed.step();
  EXPECT_TRUE(same_state(straight, resumed));
  const GaussianField &a = *straight.scene().gaussians, &b = *resumed.scene().gaussians;
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a.albedo[i].x, b.albedo[i].x);
    ASSERT_EQ(a.roughness[i], b.roughness[i]);
  }
  EXPECT_EQ(straight.environment_image().pixels, resumed.environment_image().pixels);
  ASSERT_EQ(resumed.log().size(), 6u);
  for (size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(resumed.log()[i].loss, straight.log()[i].loss) << i;
    EXPECT_EQ(resumed.log()[i].views, straight.log()[i].views) << i;
  }

  // A checkpoint of a different problem is refused, naming the difference.
  OptimizerSettings other = s;
  other.integrator.spp = 3;
  Optimizer wrong(input_scene(fx.n), fx.data, other);
  try {
    wrong.load_checkpoint(ckpt);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("spp: checkpoint 2, now 3"), std::string::npos) << e.what();
  }
}

TEST(Optimizer, CancelLeavesTheStateOfTheLastIteration) {
  const test::OptimizerFixture& fx = fixture();
  Optimizer opt(input_scene(fx.n), fx.data, small_settings());
  opt.step();
  Parameters before = opt.parameters();
  std::atomic<bool> cancel{true};
  EXPECT_THROW(opt.step(&cancel), Cancelled);
  EXPECT_EQ(opt.iteration(), 1);
  EXPECT_EQ(opt.parameters().groups[0].raw, before.groups[0].raw);
  EXPECT_EQ(opt.log().size(), 1u);

  RunOptions ro;
  ro.cancel = &cancel;
  EXPECT_EQ(run_optimizer(opt, ro), RunResult::Cancelled);
  EXPECT_EQ(opt.iteration(), 1);
  int calls = 0;
  ro.cancel = nullptr;
  ro.on_iteration = [&](const IterationLog&) { return ++calls < 2; };
  EXPECT_EQ(run_optimizer(opt, ro), RunResult::Cancelled);
  EXPECT_EQ(opt.iteration(), 3);
}

TEST(Optimizer, LossDecreasesAndOutputsAreWritten) {
  const test::OptimizerFixture& fx = fixture();
  OptimizerSettings s = small_settings();
  s.iterations = 60;
  s.integrator.spp = 4;
  Optimizer opt(input_scene(fx.n), fx.data, s);
  const fs::path d = fresh_dir("outputs");
  RunOptions ro;
  ro.out_dir = d.string();
  ro.checkpoint_every = 25;
  EXPECT_EQ(run_optimizer(opt, ro), RunResult::Finished);
  ASSERT_EQ(opt.log().size(), 60u);
  double first = 0, last = 0;
  for (int i = 0; i < 8; ++i) first += opt.log()[size_t(i)].image / 8;
  for (int i = 52; i < 60; ++i) last += opt.log()[size_t(i)].image / 8;
  EXPECT_LT(last, 0.7 * first) << "first " << first << " last " << last;

  GaussianField out = load_gaussians((d / "gaussians.ply").string());
  ASSERT_EQ(out.size(), fx.n);
  EXPECT_TRUE(out.normals_from_file);
  // The outputs are the last iterate.
  for (size_t i = 0; i < out.size(); ++i) ASSERT_EQ(out.albedo[i].x, opt.scene().gaussians->albedo[i].x);
  Image env = read_image((d / "env.exr").string());
  EXPECT_EQ(env.width, 16);
  EXPECT_EQ(env.height, 8);
  std::ifstream csv(d / "log.csv");
  std::string line;
  int lines = 0;
  while (std::getline(csv, line)) ++lines;
  EXPECT_EQ(lines, 61);
  Checkpoint c = read_checkpoint((d / "checkpoint.bin").string());
  EXPECT_EQ(c.iteration, 60u);
}

TEST(Optimizer, MaterialMapsEqualTheAovRenders) {
  const test::OptimizerFixture& fx = fixture();
  Optimizer opt(input_scene(fx.n), fx.data, small_settings());
  Parameters p = opt.parameters();
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (ParameterGroup& g : p.groups)
    for (float& x : g.raw) x += u(rng);
  opt.set_parameters(p);
  for (InteractionMode mode : {InteractionMode::Aggregate, InteractionMode::Discrete}) {
    AovSettings as;
    as.seed = 11;
    as.interaction.mode = mode;
    Camera cam = fx.data->views[1].camera.crop(3, 2, 17, 15);
    Image a, r, c;
    render_material_maps(opt.tracer().accel(), cam, as, {}, &a, &r, &c);
    Image ra = render_aov(opt.tracer().accel(), cam, Aov::Albedo, as);
    Image rr = render_aov(opt.tracer().accel(), cam, Aov::Roughness, as);
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) {
        for (int ch = 0; ch < 3; ++ch) ASSERT_EQ(a.at(x, y, ch), ra.at(x, y, ch));
        ASSERT_EQ(r.at(x, y, 0), rr.at(x, y, 0));
        ASSERT_EQ(c.at(x, y, 0), ra.at(x, y, 3));
      }
  }
}

TEST(Optimizer, SchedulesFollowTheirDefinitions) {
  const test::OptimizerFixture& fx = fixture();
  OptimizerSettings s = small_settings();
  s.iterations = 100;
  s.lr_final = 0.1f;
  s.lr_decay_start = 0.5f;
  s.albedo_warmup = 0.2f;
  s.tv_warmup = 5.0f;
  Optimizer opt(input_scene(fx.n), fx.data, s);
  // Learning rate: 1 up to 50 %, then exponential to 0.1 at the last iteration.
  EXPECT_DOUBLE_EQ(opt.lr_factor(0), 1.0);
  EXPECT_DOUBLE_EQ(opt.lr_factor(50), 1.0);
  EXPECT_NEAR(opt.lr_factor(99), 0.1, 1e-6);
  EXPECT_NEAR(opt.lr_factor(75), std::pow(0.1, 25.0 / 49.0), 1e-6);
  // Materials ramp from 1/20 to 1 over the first 20 iterations.
  EXPECT_NEAR(opt.albedo_lr_factor(0), 0.05, 1e-6);
  EXPECT_NEAR(opt.albedo_lr_factor(9), 0.5, 1e-6);
  EXPECT_NEAR(opt.albedo_lr_factor(19), 1.0, 1e-6);
  EXPECT_DOUBLE_EQ(opt.albedo_lr_factor(80), 1.0);
  // TV: 5x at the start, falling linearly to 1x at iteration 50.
  EXPECT_NEAR(opt.tv_weight(0), 5.0 * s.lambda_tv, 1e-6);
  EXPECT_NEAR(opt.tv_weight(25), 3.0 * s.lambda_tv, 1e-6);
  EXPECT_NEAR(opt.tv_weight(50), s.lambda_tv, 1e-6);
  EXPECT_NEAR(opt.tv_weight(90), s.lambda_tv, 1e-6);
}
