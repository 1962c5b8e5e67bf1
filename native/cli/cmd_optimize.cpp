// `ptir optimize`: recover per-Gaussian materials and the environment from
// posed images (METHOD §6; src/ptir/optim/optimizer.h).
//
//   ptir optimize --dataset DIR --gaussians IN.ply [--scene scene.json] --out OUT
//       [--iters N] [--spp N] [--bounces N] [--env latlong|sg] [--seed S] [--resume]
//       [--split train] [--prior DIR] [--views-per-iter K] [--crop N] [--checkpoint-every N]
//       [--threads N] [--loss-space srgb|linear] [--lambda-tv X] [--optimize-metallic]
//       [--optimize-meshes] [--env-size WxH] [--env-init MAP [--fix-env]] [-q]
//
// Writes OUT/gaussians.ply (every input property + albedo_0..2, roughness,
// metallic, nx,ny,nz), OUT/env.exr (lat-long, Blender orientation like the
// inputs), OUT/log.csv and OUT/checkpoint.bin (every --checkpoint-every
// iterations and at the end), all atomically. --resume continues from
// OUT/checkpoint.bin exactly (bit-identical on the same thread count); only
// --iters may differ from the interrupted run. One progress line per iteration
// on stderr. Ctrl-C stops after the last completed iteration, writes the
// checkpoint and the outputs, and exits 130 (a second Ctrl-C kills at once).
//
// --scene adds the scene file's meshes and lights (its Gaussians must be given
// with --gaussians instead; its environment is replaced by the recovered one; its
// interaction settings are used, its spp/bounces are not: inversion defaults
// are 32 spp, 2 bounces).
#include <tbb/global_control.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "commands.h"
#include "filter_flags.h"
#include "ptir/core/error.h"
#include "ptir/io/dataset.h"
#include "ptir/optim/optimizer.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/scene.h"
#include "ptir/scene/scene_json.h"

namespace ptir::cli {

namespace {

struct OptimizeOptions {
  std::string dataset, gaussians, scene, out;
  std::string split = "train";
  std::string prior;
  int iters = 800;
  int spp = 32;
  int bounces = 2;
  std::string env = "latlong";
  std::string env_size = "128x64";
  std::string env_init;
  bool fix_env = false;
  uint64_t seed = 0;
  bool resume = false;
  int views_per_iter = 1;
  int crop = 0;
  int checkpoint_every = 50;
  int threads = 0;
  std::string loss_space = "srgb";
  float lambda_tv = 0.095f;
  bool optimize_metallic = false;
  bool optimize_meshes = false;
  FilterFlags filter;
  bool quiet = false;
};

std::atomic<bool> g_interrupted{false};

extern "C" void on_sigint(int) {
  g_interrupted.store(true);
  std::signal(SIGINT, SIG_DFL);  // a second Ctrl-C ends the process at once
}

std::string duration_text(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  long t = long(s + 0.5);
  char b[32];
  if (t >= 3600) std::snprintf(b, sizeof b, "%ldh%02ldm", t / 3600, (t / 60) % 60);
  else if (t >= 60) std::snprintf(b, sizeof b, "%ldm%02lds", t / 60, t % 60);
  else std::snprintf(b, sizeof b, "%.1fs", s);
  return b;
}

int run_optimize(const OptimizeOptions& o, const CLI::App& cmd) {
  std::optional<tbb::global_control> limit;
  if (o.threads < 0) throw Error("--threads must be positive");
  if (o.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(o.threads));
  if (o.iters < 0) throw Error("--iters must be >= 0");
  if (o.checkpoint_every < 0) throw Error("--checkpoint-every must be >= 0");

  OptimizerSettings s;
  s.iterations = o.iters;
  s.integrator.spp = o.spp;
  s.integrator.max_bounces = o.bounces;
  s.seed = o.seed;
  s.views_per_iteration = o.views_per_iter;
  s.crop_size = o.crop;
  s.lambda_tv = o.lambda_tv;
  if (o.loss_space == "srgb") s.srgb_loss = true;
  else if (o.loss_space == "linear") s.srgb_loss = false;
  else throw Error("--loss-space must be 'srgb' or 'linear', got '" + o.loss_space + "'");
  if (o.env == "latlong") s.params.env = EnvMode::LatLong;
  else if (o.env == "sg") s.params.env = EnvMode::SG;
  else throw Error("--env must be 'latlong' or 'sg', got '" + o.env + "'");
  {
    int w = 0, h = 0;
    char extra = 0;
    if (std::sscanf(o.env_size.c_str(), "%dx%d%c", &w, &h, &extra) != 2 || w < 1 || h < 1)
      throw Error("--env-size must be WIDTHxHEIGHT (e.g. 128x64), got '" + o.env_size + "'");
    s.params.env_width = w;
    s.params.env_height = h;
  }
  s.params.env_init_path = o.env_init;
  s.params.optimize_env = !o.fix_env;
  if (o.fix_env && o.env_init.empty()) throw Error("--fix-env needs --env-init (the known environment map)");
  s.params.optimize_metallic = o.optimize_metallic;
  s.params.optimize_meshes = o.optimize_meshes;
  if (o.spp < 1) throw Error("--spp must be at least 1");
  if (o.bounces < 0) throw Error("--bounces must be at least 0");

  // Inputs.
  DatasetOptions dopt;
  dopt.split = o.split;
  dopt.prior_dir = o.prior;
  std::shared_ptr<const Dataset> data = load_dataset(o.dataset, dopt);
  // The filter the views were rendered with (dataset.json), else Blender's default; the switches override it.
  s.integrator.filter = dataset_pixel_filter(*data);
  apply_filter_flags(o.filter, cmd, s.integrator.filter);
  Scene scene;
  if (!o.scene.empty()) {
    scene = load_scene_json(o.scene);
    if (scene.gaussians && scene.gaussians->size() > 0)
      throw Error(o.scene, "the scene file has Gaussians; give them with --gaussians instead (the optimiser's Gaussians "
                           "come from one PLY)");
    if (scene.environment.present() && !o.quiet)
      std::fprintf(stderr, "note: the scene's environment is ignored: the environment is what gets recovered\n");
    s.integrator.interaction = scene.integrator.interaction;
    s.integrator.geometric_criterion = scene.integrator.geometric_criterion;
    s.integrator.self_intersection = scene.integrator.self_intersection;
    s.integrator.self_range_scale = scene.integrator.self_range_scale;
    s.integrator.fixed_offset = scene.integrator.fixed_offset;
    s.integrator.fixed_range = scene.integrator.fixed_range;
  } else if (o.optimize_meshes) {
    throw Error("--optimize-meshes needs --scene (the meshes come from the scene file)");
  }
  scene.gaussians = std::make_shared<GaussianField>(load_gaussians(o.gaussians));
  scene.source_path = o.scene.empty() ? "command line" : o.scene;

  Optimizer opt(std::move(scene), data, s);
  const std::string ckpt = (std::filesystem::path(o.out) / "checkpoint.bin").string();
  if (o.resume) {
    if (!std::filesystem::exists(ckpt)) throw Error(ckpt, "--resume: no checkpoint to continue from");
    opt.load_checkpoint(ckpt);
    if (!o.quiet)
      std::fprintf(stderr, "resumed from %s at iteration %d\n", ckpt.c_str(), opt.iteration());
  }
  if (!o.quiet)
    std::fprintf(stderr,
                 "optimize: %zu Gaussians, %zu %s views %dx%d%s, %d iterations, %d spp, %d bounces, env %s, seed %llu\n",
                 opt.scene().gaussians->size(), data->size(), data->split.c_str(), data->width, data->height,
                 data->has_priors() ? " (with priors)" : "", o.iters, o.spp, o.bounces, o.env.c_str(),
                 (unsigned long long)o.seed);

  g_interrupted.store(false);
  auto previous = std::signal(SIGINT, on_sigint);
  const int start_it = opt.iteration();
  const auto t0 = std::chrono::steady_clock::now();
  RunOptions ro;
  ro.out_dir = o.out;
  ro.checkpoint_every = o.checkpoint_every;
  ro.cancel = &g_interrupted;
  ro.on_iteration = [&](const IterationLog& l) {
    if (o.quiet) return true;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const int done = opt.iteration() - start_it;
    const double per = done > 0 ? elapsed / done : l.seconds;
    const double eta = per * double(opt.settings().iterations - opt.iteration());
    std::fprintf(stderr, "iter %d/%d  loss %.5f (image %.5f tv %.5f prior %.5f)  %.2f s/iter  ETA %s  [%s]\n", l.iteration,
                 opt.settings().iterations, l.loss, l.image, l.tv, l.prior, l.seconds, duration_text(eta).c_str(),
                 l.views.c_str());
    return true;
  };
  RunResult r;
  try {
    r = run_optimizer(opt, ro);
  } catch (...) {
    std::signal(SIGINT, previous);
    throw;
  }
  std::signal(SIGINT, previous);
  if (opt.nonfinite_gradients() > 0 && !o.quiet)
    std::fprintf(stderr, "warning: %zu non-finite gradient entries were dropped\n", opt.nonfinite_gradients());
  if (r == RunResult::Cancelled) {
    std::fprintf(stderr, "ptir: interrupted after iteration %d; wrote %s and the outputs in %s (continue with --resume)\n",
                 opt.iteration(), ckpt.c_str(), o.out.c_str());
    return 130;
  }
  if (!o.quiet)
    std::fprintf(stderr, "wrote %s/gaussians.ply, env.exr, log.csv (%d iterations)\n", o.out.c_str(), opt.iteration());
  (void)cmd;
  return 0;
}

}  // namespace

Runner add_optimize_command(CLI::App& app) {
  auto o = std::make_shared<OptimizeOptions>();
  CLI::App* cmd = app.add_subcommand("optimize", "Recover materials and lighting from posed images (inverse rendering)");
  cmd->add_option("--dataset", o->dataset, "dataset folder (NeRF-synthetic / TensoIR layout: transforms_<split>.json)")
      ->required();
  cmd->add_option("--gaussians", o->gaussians, "input 3DGS .ply (geometry, fixed)")->required();
  cmd->add_option("--scene", o->scene, "scene file with meshes and lights to include (docs/scene_format.md)");
  cmd->add_option("--out", o->out, "output folder")->required();
  cmd->add_option("--iters", o->iters, "iterations")->capture_default_str();
  cmd->add_option("--spp", o->spp, "samples per pixel per iteration")->capture_default_str();
  cmd->add_option("--bounces", o->bounces, "indirect bounces")->capture_default_str();
  cmd->add_option("--env", o->env, "environment model: latlong (texels) or sg (24 spherical Gaussians)")->capture_default_str();
  cmd->add_option("--env-size", o->env_size, "lat-long environment size WxH")->capture_default_str();
  cmd->add_option("--env-init", o->env_init, "start from this lat-long map (.exr/.hdr, Blender orientation) instead of a constant");
  cmd->add_flag("--fix-env", o->fix_env, "keep the --env-init environment fixed (known lighting)");
  cmd->add_option("--seed", o->seed, "random seed (views, crops, paths)")->capture_default_str();
  cmd->add_flag("--resume", o->resume, "continue from OUT/checkpoint.bin");
  cmd->add_option("--split", o->split, "dataset split (transforms_<split>.json)")->capture_default_str();
  cmd->add_option("--prior", o->prior, "folder of prior albedo/roughness maps in the dataset's layout");
  cmd->add_option("--views-per-iter", o->views_per_iter, "training views per iteration")->capture_default_str();
  cmd->add_option("--crop", o->crop, "random square crops of this side (0: whole images)")->capture_default_str();
  cmd->add_option("--checkpoint-every", o->checkpoint_every, "iterations between checkpoints (0: only at the end)")
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "limit worker threads (0: all); resumed runs are bit-identical on the same count");
  cmd->add_option("--loss-space", o->loss_space, "compare images in srgb or linear space")->capture_default_str();
  cmd->add_option("--lambda-tv", o->lambda_tv, "weight of the edge-aware TV regulariser")->capture_default_str();
  cmd->add_flag("--optimize-metallic", o->optimize_metallic, "also optimise metallic (default: fixed 0)");
  cmd->add_flag("--optimize-meshes", o->optimize_meshes, "also optimise the --scene meshes' materials");
  add_filter_flags(cmd, &o->filter);
  cmd->add_flag("-q,--quiet", o->quiet, "no progress output");
  return [o, cmd] { return run_optimize(*o, *cmd); };
}

}  // namespace ptir::cli
