// `ptir optimize`: recover per-Gaussian materials and the environment from
// posed images (docs/method.md §6, §9). The command line of the optimise
// pipeline (src/ptir/pipeline/optimize_pipeline.h: its stages, budget, resume,
// outputs and progress are there, shared with the Python module).
//
//   ptir optimize --dataset DIR [--gaussians IN.ply] [--scene scene.json] --out OUT
//       [--fit-iters 1500] [--iters N] [--spp N] [--bounces N] [--env auto|latlong|sg|color|none] [--seed S] [--resume]
//       [--layout L] [--images images_4] [--holdout 8 | --test-list F] [--undistort-cache D]
//       [--dataparser-transforms F] [--world auto|data|dataparser|colmap] [--black-background]
//       [--split train] [--prior DIR] [--views-per-iter K] [--crop N] [--checkpoint-every N]
//       [--threads N] [--loss-space srgb|linear] [--lambda-tv X] [--optimize-metallic]
//       [--optimize-meshes] [--env-size WxH] [--env-init MAP [--fix-env | --env-refine] [--env-align auto|yaw|full|search|off]]
//       [--estimate] [--budget 10m] [--progress text|json] [-q]
//   ptir optimize --gaussians IN.ply --out OUT [--cameras cameras.json]   (targets from the splats' own radiance)
//
// --scene adds the scene file's meshes and lights (its Gaussians must be given
// with --gaussians instead; its environment is replaced by the recovered one; its
// interaction settings are used, its spp/bounces are not: inversion defaults
// are 32 spp, 2 bounces). Its lights and meshes are fixed (known light and
// occluders; --optimize-meshes learns the meshes' materials); --env none removes
// the environment, so they are the only light (docs/known_lamps.md).
// Exit status: 0, 2 for a usage error, 130 when Ctrl-C
// stopped it (the checkpoint and the outputs written; --resume continues).
#include <memory>
#include <set>
#include <string>

#include "brdf_option.h"
#include "capture_flags.h"
#include "commands.h"
#include "filter_flags.h"
#include "help_groups.h"
#include "optimize_flags.h"
#include "output_guard.h"
#include "pyramid_flags.h"
#include "radiance_flags.h"
#include "ptir/pipeline/optimize_pipeline.h"
#include "world.h"

namespace ptir::cli {

namespace {

using pipeline::OptimizePipelineOptions;

// `--help` lists the options most runs need (help_groups.h); `--help-all` every one.
const std::set<std::string> kCommonOptions = {
    "--help", "--help-all", "--dataset", "--gaussians", "--scene", "--out", "--fit-iters", "--iters", "--spp",
    "--bounces", "--env", "--env-size", "--env-init", "--seed", "--brdf", "--resume", "--threads",
    "--checkpoint-every", "--images", "--holdout", "--optimize-metallic", "--learn-exposure", "--estimate",
    "--quiet", "--force", "--budget"};

// --env-align (optim/env_align.h; docs/known_light.md).
const char* const kEnvAlignHelp =
    "line the --env-init map up with the photos first: auto (its yaw, and its exposure and white balance where the "
    "photos see the background; on masked photos with --fix-env, its exposure from short inversions at candidate "
    "levels), yaw (the yaw only: the map's level kept), full (on masked photos an exposure that makes the object's "
    "mean albedo 0.5), search (the short inversions, the map fixed or learnt) or off (as given); recorded in "
    "OUT/settings.json";

// The inputs, the stages' and the run's options (in the --help-all order).
CLI::App* add_run_flags(CLI::App& app, OptimizePipelineOptions* o) {
  CLI::App* cmd = app.add_subcommand("optimize", "Recover materials and lighting from posed images (inverse rendering)");
  cmd->add_option("--dataset", o->dataset,
                  "dataset folder: NeRF-synthetic/TensoIR (transforms_<split>.json), COLMAP (sparse/0), 3DGS output "
                  "(cameras.json + cfg_args) or nerfstudio (transforms.json); docs/dataset_format.md. Without it, "
                  "--gaussians alone: the inversion runs on targets rendered from the splats' own radiance "
                  "(docs/relightable.md)");
  cmd->add_option("--gaussians", o->gaussians,
                  "input 3DGS .ply (its geometry fitted first unless --fit-iters 0, then fixed); default for a 3DGS output folder: point_cloud/iteration_N (largest N)");
  cmd->add_option("--scene", o->scene, "scene file with meshes and lights to include (docs/scene_format.md)");
  cmd->add_option("--fit-iters", o->fit_iters,
                  "geometry stage first: iterations of `ptir fit` on the splats, into OUT/fit/ (0: keep the splats' "
                  "geometry; skipped with --scene meshes and under MPI; a trained splat on real photos: half refit its "
                  "colours on its own geometry, half refine from there, the better on the held-out photos kept)")
      ->capture_default_str();
  cmd->add_option("--out", o->out, "output folder")->required();
  cmd->add_option("--subject", o->subject,
                  "real captures: the splat is an object against a background (its coverage masks the photos, the "
                  "background starts the environment), the whole scene, or auto (from its coverage of the photos)")
      ->capture_default_str();
  cmd->add_option("--iters", o->opt.iters, "iterations")->capture_default_str();
  cmd->add_option("--spp", o->opt.spp, "samples per pixel per iteration")->capture_default_str();
  cmd->add_option("--bounces", o->opt.bounces, "indirect bounces")->capture_default_str();
  cmd->add_option("--indirect", o->opt.indirect,
                  "light a ray leaving a vertex brings back from the splats: path (another vertex, shaded with the "
                  "current materials and light), field (the splats' captured SH radiance) or auto (field when the "
                  "geometry stage fitted the splats to these photos, else path)")
      ->capture_default_str();
  cmd->add_option("--env", o->opt.env,
                  "environment model: latlong (texels), sg (24 spherical Gaussians), color (one constant colour) or "
                  "none (no environment: the --scene file's lamps and emissive meshes are the only, known, light); "
                  "auto: latlong (for every layout)")
      ->capture_default_str();
  cmd->add_option("--env-size", o->env_size, "lat-long environment size WxH")->capture_default_str();
  cmd->add_option("--env-init", o->opt.env_init, "start from this lat-long map (.exr/.hdr, Blender orientation) instead of a constant");
  cmd->add_flag("--fix-env", o->opt.fix_env, "keep the --env-init environment fixed (known lighting)");
  cmd->add_option("--env-align", o->opt.env_align, kEnvAlignHelp)->capture_default_str();
  cmd->add_flag("--env-refine", o->opt.env_refine,
                "learn the (aligned) --env-init map gently, at a tenth of the environment's rate (known light, refined)");
  cmd->add_flag("--fix-env-seen", o->opt.fix_env_seen,
                "hold the --env-init map's texels whose alpha is 1 fixed (the environment the photos saw) and learn the "
                "rest (a real capture of an object sets it with its background: docs/captures.md)");
  cmd->add_option("--env-seen", o->opt.env_seen,
                  "what the --env-init map's seen texels (alpha 1) learn: learn (like every texel), coarse (the "
                  "photos' detail kept, its change learnt smooth at the coarse level), fixed (= --fix-env-seen); auto: "
                  "coarse for a real capture's seen background, else learn")
      ->capture_default_str();
  cmd->add_option("--background-loss", o->opt.background_loss,
                  "a real capture's object: supervise every pixel of a patch, so the background seen around the "
                  "object supervises the environment, its coverage mask picking where the patches go (on, off; auto: "
                  "on for an object, docs/captures.md)")
      ->capture_default_str();
  cmd->add_option("--object-patch-share", o->opt.object_patch_share,
                  "with --background-loss: the share of patches centred on the object, the rest anywhere")
      ->capture_default_str();
  cmd->add_option("--seed", o->opt.seed, "random seed (views, crops, paths)")->capture_default_str();
  add_brdf_option(cmd, &o->brdf);
  cmd->add_flag("--resume", o->resume, "continue from OUT/checkpoint.bin");
  cmd->add_option("--split", o->split, "dataset split (transforms_<split>.json)")->capture_default_str();
  cmd->add_option("--prior", o->prior, "folder of prior albedo/roughness maps in the dataset's layout");
  cmd->add_option("--views-per-iter", o->opt.views_per_iter, "training views per iteration")->capture_default_str();
  cmd->add_option("--crop", o->opt.crop, "random square crops of this side (0: whole images)")->capture_default_str();
  add_pyramid_flags(cmd, &o->opt.coarse_pixels, &o->opt.fine_fraction);
  cmd->add_option("--coarse-spp", o->opt.coarse_spp,
                  "resolution pyramid: samples per pixel while the views are reduced (0: --spp; a budget plans it)")
      ->capture_default_str();
  cmd->add_option("--checkpoint-every", o->checkpoint_every, "iterations between checkpoints (0: only at the end)")
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "limit worker threads (0: all); resumed runs are bit-identical on the same count");
  return cmd;
}

// The run's reporting and the flag groups shared with other commands.
void add_report_flags(CLI::App* cmd, OptimizePipelineOptions* o, std::string* progress) {
  cmd->add_flag("-q,--quiet", o->quiet, "no progress output");
  cmd->add_option("--budget", o->budget,
                  "time budget for the whole run instead of --iters, e.g. 90s, 10m, 1.5h: spp and iterations are planned "
                  "from the measured cost and the count re-planned as it runs (--resume continues it)");
  cmd->add_flag("--estimate", o->estimate,
                "print the estimated duration (one JSON line: setup_s, s_per_iter, total_s) and exit without optimising");
  cmd->add_option("--progress", *progress,
                  "progress lines on stderr: text, or json (one JSON object per line: docs/engine_protocol.md)")
      ->capture_default_str();
  add_force_flag(cmd, o->force);
  add_capture_flags(cmd, &o->capture);
  add_filter_flags(cmd, &o->filter);
  add_radiance_flags(cmd, &o->radiance);
  show_common_options(cmd, kCommonOptions);
}

}  // namespace

Runner add_optimize_command(CLI::App& app) {
  auto o = std::make_shared<OptimizePipelineOptions>();
  auto progress = std::make_shared<std::string>("text");
  CLI::App* cmd = add_run_flags(app, o.get());
  add_learning_flags(cmd, &o->opt);
  add_report_flags(cmd, o.get(), progress.get());
  return [o, cmd, progress] {
    OptimizePipelineOptions options = *o;
    options.given = given_options(*cmd);
    options.progress_format = pipeline::parse_progress_format(*progress);
    return pipeline::run_optimize_pipeline(options, world());
  };
}

}  // namespace ptir::cli
