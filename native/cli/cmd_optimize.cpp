// `ptir optimize`: recover per-Gaussian materials and the environment from
// posed images (docs/method.md §6; src/ptir/optim/optimizer.h).
//
//   ptir optimize --dataset DIR [--gaussians IN.ply] [--scene scene.json] --out OUT
//       [--fit-iters 1500] [--iters N] [--spp N] [--bounces N] [--env auto|latlong|sg|color] [--seed S] [--resume]
//       [--layout L] [--images images_4] [--holdout 8 | --test-list F] [--undistort-cache D]
//       [--dataparser-transforms F] [--world auto|data|dataparser|colmap] [--black-background]
//       [--split train] [--prior DIR] [--views-per-iter K] [--crop N] [--checkpoint-every N]
//       [--threads N] [--loss-space srgb|linear] [--lambda-tv X] [--optimize-metallic]
//       [--optimize-meshes] [--env-size WxH] [--env-init MAP [--fix-env | --env-refine] [--env-align auto|yaw|full|off]]
//       [--estimate] [--budget 10m] [-q]
//
// --budget (s, m or h) instead of --iters: the whole command ends within it
// (optimize_budget.h: spp and iterations planned from the estimate, the count
// re-planned from the measured rate; OUT/budget.json lets --resume continue it).
//
// Without --dataset (`ptir optimize --gaussians IN.ply --out OUT [--cameras cameras.json]`):
// the targets are rendered from the splats' own radiance (radiance_stage.h,
// docs/relightable.md), with defaults of their own (400 iterations, 16 spp, 128 crops).
//
// First the geometry stage (--fit-iters, `ptir fit` into OUT/fit/; 0: none; see
// geometry_stage below), then the inversion on the fitted splats.
// Writes OUT/gaussians.ply (every input property + albedo_0..2, roughness,
// metallic, nx,ny,nz), OUT/env.exr (lat-long, Blender orientation like the
// inputs), OUT/log.csv and OUT/checkpoint.bin (every --checkpoint-every
// iterations and at the end), all atomically. --resume continues from
// OUT/checkpoint.bin exactly (bit-identical on the same thread count); only
// --iters may differ from the interrupted run. One progress line per iteration
// on stderr. Ctrl-C stops after the last completed iteration, writes the
// checkpoint and the outputs, and exits 130 (a second Ctrl-C kills at once).
//
// --estimate loads everything, times the probe of optim/iteration_estimate.h and
// prints one JSON line on stdout instead of optimising (nothing is written):
//   {"estimate": {"setup_s": S, "s_per_iter": T, "iterations": N, "total_s": S + N*T, ...}}
// setup_s is what a real run spends before its first iteration (loading the
// dataset and Gaussians, building the BVH, the probe itself, which a real run
// also does): the add-on's Optimise panel shows total_s before starting.
// Without --dataset it renders the first radiance target only (into a temp
// folder: nothing is written in OUT) and counts that view's time for each other.
// One writer per --out (output_guard.h); never a dataset's folder.
//
// --scene adds the scene file's meshes and lights (its Gaussians must be given
// with --gaussians instead; its environment is replaced by the recovered one; its
// interaction settings are used, its spp/bounces are not: inversion defaults
// are 32 spp, 2 bounces).
//
// Under MPI (`mpirun -np N ptir optimize ...`, native/mpi/world.h) every rank
// takes every view of each iteration in row bands (optim/data_parallel.h); rank 0
// alone prints progress and writes the outputs, the log and the checkpoints, and
// --resume continues from the checkpoint with any N. A stop from outside ends the
// job at once with a line naming the last checkpoint (job_stop.h).
#include <tbb/global_control.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>

#include "brdf_option.h"
#include "capture_flags.h"
#include "capture_stage.h"
#include "commands.h"
#include "optimize_budget.h"
#include "output_guard.h"
#include "run_control.h"
#include "filter_flags.h"
#include "fit_stage.h"
#include "help_groups.h"
#include "radiance_stage.h"
#include "job_stop.h"
#include "pyramid_flags.h"
#include "ptir/core/error.h"
#include "ptir/scene/dataset.h"
#include "ptir/optim/checkpoint.h"
#include "ptir/optim/iteration_estimate.h"
#include "ptir/optim/budget_plan.h"
#include "ptir/optim/optimizer.h"
#include "ptir/scene/scene_json.h"
#include "ptir/optim/optimizer_setup.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/scene.h"
#include "world.h"

namespace ptir::cli {

namespace {

// `--help` lists the options most runs need (help_groups.h); `--help-all` every one.
const std::set<std::string> kCommonOptions = {
    "--help", "--help-all", "--dataset", "--gaussians", "--scene", "--out", "--fit-iters", "--iters", "--spp",
    "--bounces", "--env", "--env-size", "--env-init", "--seed", "--brdf", "--resume", "--threads",
    "--checkpoint-every", "--images", "--holdout", "--optimize-metallic", "--learn-exposure", "--estimate",
    "--quiet", "--force", "--budget"};

// --env-align (optim/env_align.h; docs/known_light.md).
const char* const kEnvAlignHelp =
    "line the --env-init map up with the photos first: auto (its yaw, and its exposure and white balance where the "
    "photos see the background), yaw, full (auto, and on masked photos an exposure that makes the object's mean "
    "albedo 0.5) or off (as given); recorded in OUT/settings.json";

// The command's own options around the set-up shared with the Python module.
struct OptimizeCommand {
  std::string dataset, gaussians, scene, out;
  std::string brdf;  // --brdf (empty: the checkpoint's on --resume, the scene file's, the dataset's, else principled-v2)
  std::string split = "train";
  std::string prior;
  std::string env_size = "128x64";
  bool resume = false;
  int checkpoint_every = 50;
  int threads = 0;
  bool quiet = false;
  bool estimate = false;  // --estimate: print the estimated duration, do not optimise
  std::string budget;     // --budget: a time budget for the whole command (optimize_budget.h)
  OptimizeOptions opt;
  FilterFlags filter;
  bool force = false;
  CaptureFlags capture;  // real captures (docs/dataset_format.md)
  int fit_iters = 1500;  // the geometry stage first (0: the splats' geometry as given)
  bool fitted = false;   // the inversion runs on splats its geometry stage fitted (OUT/fit/)
  bool plan_fit_fine_fraction = false;  // a budget without --fine-fraction: the stage plans its own (fit_stage.h)
  double targets_left_s = 0;  // --estimate without --dataset: the radiance targets still to render
  RadianceStage radiance;  // no --dataset: targets from the splats' own radiance (radiance_stage.h)
  bool env_detail = false;  // the environment started from the photos' background: OUT/env.exr gets their detail
  std::string subject = "auto";  // --subject: a real capture's splat is an object or the scene (capture_stage.h)
  std::shared_ptr<ScratchFolder> scratch;  // --estimate without --dataset: its probe target (outside OUT)
  std::shared_ptr<PendingPlan> plan;       // without --dataset: a new plan, committed with the results
};

// The capture stage's view of the command (the input splats, the calibration so far).
CaptureStage capture_stage_of(const OptimizeCommand& o) {
  CaptureStage c{o.dataset, o.gaussians, o.out, o.capture, {}, o.resume, o.quiet};
  c.s.subject = o.subject;
  char extra = 0;
  if (std::sscanf(o.env_size.c_str(), "%dx%d%c", &c.s.env_width, &c.s.env_height, &extra) != 2 || c.s.env_width < 1 ||
      c.s.env_height < 1)
    throw Error("--env-size must be WIDTHxHEIGHT (e.g. 128x64), got '" + o.env_size + "'");
  return c;
}

// Real photos (capture_stage.h): the analysis' calibration applies to every stage, and
// an object's background seen directly starts the environment (unless --env-init).
void capture_stage(OptimizeCommand& o) {
  if (o.subject != "auto" && o.subject != "object" && o.subject != "scene")
    throw Error("--subject must be auto, object or scene, got '" + o.subject + "'");
  const CaptureStageResult r = run_capture_stage(capture_stage_of(o));
  if (r.calibration.empty()) return;
  o.capture.calibration = r.calibration;
  if (o.opt.env_init.empty() && !r.background_env.empty() && o.opt.env == "latlong") {
    // Its start, learnt from there: holding the seen texels (--fix-env-seen) measured 2 dB lower on the
    // dog's held-out object pixels (docs/captures.md: a wall and paper at infinity light it wrongly).
    o.opt.env_init = r.background_env;
    o.opt.env_align = "off";  // made from the photos: already theirs
    o.env_detail = true;
  }
}


// Defaults that depend on the dataset: the Gaussians a 3DGS output folder names
// (point_cloud/iteration_N, largest N). The environment model is the lat-long
// map for every layout (issue 38): real captures had 24 SGs, as the paper does,
// which the project's ablation measured at -3.3 / -3.8 dB albedo (sRGB / linear) against the texels
// (docs/inversion.md), and the same masked set loaded as COLMAP and as NeRF
// reached 22.1 against 24.9 dB; `--env sg` still asks for them.
// Returns false (a usage error) when --gaussians is missing and the dataset names none.
bool resolve_dataset_defaults(OptimizeCommand& o) {
  if (o.opt.env == "auto") o.opt.env = "latlong";
  if (o.dataset.empty()) {  // targets from the splats' own radiance (radiance_stage.h)
    if (o.gaussians.empty()) {
      std::fprintf(stderr, "ptir: error: give --dataset (photos and poses) or --gaussians (a splat PLY: the inversion then "
                           "runs on its own captured radiance), or both\n");
      return false;
    }
    return true;
  }
  if (o.gaussians.empty()) {
    o.gaussians = layout_gaussians(o.dataset);
    if (o.gaussians.empty()) {
      std::fprintf(stderr, "ptir: error: --gaussians is required (%s names no trained Gaussians; a 3DGS output folder does)\n",
                   o.dataset.c_str());
      return false;
    }
    if (!o.quiet) std::fprintf(stderr, "optimize: Gaussians from the dataset: %s\n", o.gaussians.c_str());
  }
  return true;
}

// The optimiser for the command's options (inputs loaded; resumed when asked).
std::unique_ptr<Optimizer> make_optimizer(const OptimizeCommand& o, const CLI::App& cmd, std::shared_ptr<const Dataset>* data) {
  OptimizeOptions opt = o.opt;
  char extra = 0;
  if (std::sscanf(o.env_size.c_str(), "%dx%d%c", &opt.env_width, &opt.env_height, &extra) != 2 || opt.env_width < 1 ||
      opt.env_height < 1)
    throw Error("--env-size must be WIDTHxHEIGHT (e.g. 128x64), got '" + o.env_size + "'");
  OptimizerSettings s = optimizer_settings(opt, cli_option_name);

  DatasetOptions dopt;
  dopt.split = o.split;
  dopt.prior_dir = o.prior;
  apply_capture_flags(o.capture, dopt);
  *data = load_dataset(o.dataset, dopt);
  if (!o.estimate) (*data)->check_images();  // every photo decodes and fits its camera, before any iteration
  // The filter the views were rendered with (dataset.json), else Blender's default; the switches override it.
  s.integrator.filter = dataset_pixel_filter(**data);
  apply_filter_flags(o.filter, cmd, s.integrator.filter);
  auto note = [&](const std::string& line) {
    if (!o.quiet) std::fprintf(stderr, "note: %s\n", line.c_str());
  };
  Scene scene = prepare_optimizer_scene(o.scene, std::make_shared<GaussianField>(load_gaussians(o.gaussians)), s,
                                        cli_option_name, note);
  // The model: --brdf; else a resumed run's own (its checkpoint's: "principled" = v1);
  // else the scene file's, the dataset's recorded one, or principled-v2.
  const std::string ckpt = (std::filesystem::path(o.out) / "checkpoint.bin").string();
  s.integrator.brdf = resolve_bsdf_model(scene.brdf_from_file, s.integrator.brdf, (*data)->brdf);
  if (o.resume && o.brdf.empty() && std::filesystem::exists(ckpt))
    for (const auto& kv : read_checkpoint(ckpt).fingerprint)
      if (kv.first == "brdf" && parse_bsdf_model(kv.second)) s.integrator.brdf = *parse_bsdf_model(kv.second);
  cli::apply_brdf_option(o.brdf, s.integrator.brdf);
  if (!o.quiet) std::fprintf(stderr, "optimize: surface model %s\n", to_string(s.integrator.brdf));
  auto optimizer = std::make_unique<Optimizer>(std::move(scene), *data, s);
  if (!o.quiet && optimizer->env_alignment().mode != EnvAlignMode::Off)
    std::fprintf(stderr, "optimize: %s\n", optimizer->env_alignment().summary().c_str());
  if (o.resume) {
    std::error_code ec;
    if (!std::filesystem::exists(ckpt, ec)) throw Error(ckpt, "--resume: no checkpoint to continue from");
    optimizer->load_checkpoint(ckpt);
    if (!o.quiet) std::fprintf(stderr, "resumed from %s at iteration %d\n", ckpt.c_str(), optimizer->iteration());
  }
  return optimizer;
}

// The stop line of a data-parallel run (job_stop.h) after `done` iterations, the
// checkpoint holding iteration `saved` (< 0: none yet).
std::string stop_message(const std::string& ckpt, int done, int saved) {
  std::string m = "ptir: the MPI job was stopped after iteration " + std::to_string(done) +
                  " (a rank failed, or the job was cancelled or ran out of time); ";
  if (saved < 0) return m + "no checkpoint was written yet";
  return m + ckpt + " holds iteration " + std::to_string(saved) +
         " or later: continue with --resume (any number of ranks)";
}

// The geometry stage (docs/method.md §9, `ptir fit`) before the materials:
// the splats are fitted to the training views into OUT/fit/, and the inversion
// runs on OUT/fit/gaussians.ply. Skipped, with a note, where it cannot model the
// images: a --scene with meshes (walls and floors in the views, which the fit
// does not trace) and data-parallel runs (run `ptir fit` first there). With
// --resume: an inversion already under way (OUT/checkpoint.bin) keeps the fitted
// splats it started from; a fit that was stopped continues from its checkpoint.
// Returns 0, or 130 when Ctrl-C stopped the fit.
int geometry_stage(OptimizeCommand& o, const Communicator& comm, double fit_seconds) {
  namespace fs = std::filesystem;
  if (o.fit_iters < 0) throw Error("--fit-iters must be >= 0");
  const fs::path fit_dir = fs::path(o.out) / "fit";
  const std::string fitted = (fit_dir / "gaussians.ply").string();
  std::error_code ec;
  if (o.resume && fs::exists(fs::path(o.out) / "checkpoint.bin", ec)) {
    if (fs::exists(fitted, ec) && !fit_kept_input(fit_dir.string())) {
      o.gaussians = fitted;
      o.fitted = true;
    }
    return 0;
  }
  if (o.estimate) return 0;  // the estimate is the inversion's alone
  const bool fit_resumes = o.resume && fs::exists(fit_dir / "checkpoint.bin", ec);
  if (o.resume && !fit_resumes)
    throw Error((fs::path(o.out) / "checkpoint.bin").string(), "--resume: no checkpoint to continue from");
  o.resume = false;  // the inversion had not started: it starts after the fit
  if (fit_resumes && o.fit_iters == 0)
    throw Error((fit_dir / "checkpoint.bin").string(), "--resume: this geometry fit did not finish; continue it with --fit-iters N");
  if (o.fit_iters == 0) return 0;
  auto skip = [&](const char* why) {
    if (!o.quiet) std::fprintf(stderr, "note: geometry fit skipped: %s (--fit-iters 0 skips it always)\n", why);
    return 0;
  };
  if (comm.size() > 1) return skip("data-parallel runs take fitted splats (run `ptir fit` first)");
  if (!o.scene.empty() && !load_scene_json(o.scene).meshes.empty())
    return skip("the scene has meshes, which the fit does not trace");
  FitStage f;
  f.dataset = o.dataset;
  f.gaussians = o.gaussians;
  f.out = fit_dir.string();
  f.split = o.split;
  f.resume = fit_resumes;
  f.quiet = o.quiet;
  f.checkpoint_every = o.checkpoint_every > 0 ? 200 : 0;
  f.seconds = fit_seconds;
  f.s.iterations = o.fit_iters;
  f.s.seed = o.opt.seed;
  f.s.coarse_pixels = o.opt.coarse_pixels;  // the command's resolution pyramid, for both stages
  f.s.fine_fraction = o.opt.fine_fraction;
  f.plan_fine_fraction = o.plan_fit_fine_fraction && fit_seconds > 0.0;
  f.capture = o.capture;
  remove_stale_outputs({f.out}, o.quiet);
  const int rc = run_fit_stage(f, "ptir optimize ... --resume");
  if (rc == 0 && !keep_fitted_geometry(capture_stage_of(o), fitted)) return 0;  // the input splats stay
  o.gaussians = fitted;
  o.fitted = true;
  return rc;
}

// No --dataset: the targets are rendered from the splats' own radiance into
// OUT/radiance/ (cached: a run stopped there re-uses them), which then is the
// dataset; no geometry stage (the targets are the splats' own). With SH degree 0
// the targets do not change with the view: roughness and metallic stay at their
// priors (their learning rates are 0), and the run says so.
int radiance_stage(OptimizeCommand& o, const CLI::App& cmd, const Communicator& comm) {
  o.radiance.gaussians = o.gaussians;
  o.radiance.out = o.out;
  o.radiance.quiet = o.quiet || comm.rank() != 0;
  o.radiance.estimate = o.estimate;
  std::error_code ec;
  if (o.resume && !std::filesystem::exists(std::filesystem::path(o.out) / "checkpoint.bin", ec))
    o.resume = false;  // stopped before the first checkpoint: the cached targets are the progress
  if (o.estimate) {  // the probe's target in a scratch folder: the estimate writes nothing in OUT
    long pid = long(::getpid());
    comm.broadcast(&pid, sizeof pid, 0);
    o.scratch = std::make_shared<ScratchFolder>(pid);
    o.radiance.estimate_dir = o.scratch->path();
  }
  int degree = 0;
  if (comm.rank() == 0) {
    if (const int rc = run_radiance_stage(o.radiance, &o.dataset, &degree, &o.targets_left_s, &o.plan)) return rc;
  } else {
    degree = load_gaussians(o.gaussians).sh_degree;
  }
  char staged = o.plan != nullptr;  // the targets in OUT/radiance, or staged (radiance_stage.h)
  comm.broadcast(&staged, 1, 0);
  o.dataset = o.estimate ? o.radiance.estimate_dir
                         : (std::filesystem::path(o.out) / (staged ? kPlanStaging : "") / "radiance").string();
  if (degree == 0) {
    if (!o.quiet)
      std::fprintf(stderr, "note: the splats have SH degree 0 (no view-dependent colour): roughness and metallic are "
                           "unconstrained by their radiance and stay at their priors (%s)\n",
                   o.opt.init_from_ply ? "the PLY's values" : "roughness 0.6, metallic 0");
    o.opt.lr_roughness = 0;
    o.opt.optimize_metallic = false;
  }
  return 0;
}

int run_optimize(const OptimizeCommand& options, const CLI::App& cmd) {
  const auto t_start = std::chrono::steady_clock::now();
  // Data-parallel runs (world.h): rank 0 alone reports and writes.
  const Communicator& comm = world();
  OptimizeCommand o = options;
  if (comm.rank() != 0) o.quiet = true;
  std::optional<tbb::global_control> limit;
  if (o.threads < 0) throw Error("--threads must be positive");
  if (o.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(o.threads));
  if (o.checkpoint_every < 0) throw Error("--checkpoint-every must be >= 0");
  Inputs in{{o.gaussians, o.opt.env_init}, {o.dataset, o.prior}, {o.scene}, {o.dataset}};
  for (const std::string& f : radiance_input_files(o.radiance)) in.files.push_back(f);
  guard_outputs(in, {{}, {o.out}}, o.force);
  std::unique_ptr<io::OutputLock> lock;  // one writer per folder; --estimate writes nothing in OUT
  if (comm.rank() == 0 && !o.estimate) {
    guard_result_folder(o.out, o.force);
    lock = lock_output_folder(o.out, "ptir optimize");
    remove_stale_outputs({o.out}, o.quiet);
  }
  if (o.dataset.empty()) apply_radiance_defaults(o.opt, cmd);  // first: a resumed budget's spp goes over them
  // A time budget (optimize_budget.h): given, or kept by the run --resume continues.
  BudgetState budget;
  if (!o.budget.empty()) {
    if (cmd.count("--iters"))
      throw Error("give --iters or --budget, not both (--iters: a reproducible run; --budget: one that ends in time)");
    budget.budget_s = parse_duration(o.budget, "--budget");
  }
  bool budgeted = budget.budget_s > 0.0;  // (a budgeted run resumed with --iters keeps its batch)
  if (o.resume && !o.estimate) {
    const BudgetState kept = read_budget_state(o.out);
    budgeted = budgeted || kept.budget_s > 0.0;
    if (kept.spp > 0 && !cmd.count("--spp")) o.opt.spp = kept.spp;  // the planned samples go on
    if (kept.spp > 0 && !cmd.count("--coarse-spp")) o.opt.coarse_spp = kept.coarse_spp;
    if (kept.budget_s > 0.0 && !cmd.count("--iters")) {
      if (budget.budget_s == 0.0) budget.budget_s = kept.budget_s;
      budget.spent_s = kept.spent_s;
      budget.spp = kept.spp;
      budget.coarse_spp = kept.coarse_spp;
    }
  } else if (!o.resume && !o.estimate && budget.budget_s == 0.0 && comm.rank() == 0) {
    std::error_code ec_budget;  // a fresh run without a budget: an older run's budget is stale
    std::filesystem::remove(std::filesystem::path(o.out) / "budget.json", ec_budget);
  }
  if (budget.budget_s > 0.0 && comm.size() > 1)
    throw Error("--budget is for single-process runs (each MPI rank would plan its own count): use --iters");
  if (budgeted) {
    // A budget takes the automatic batch (optim/patch_batch.h: patches across the views where a view
    // is larger than the batch), unless given: its iterations then cost the same at any photo size.
    // --iters runs keep whole views (the measured defaults; docs/performance.md#time-to-quality).
    if (!cmd.count("--views-per-iter")) o.opt.views_per_iter = 0;
    if (!cmd.count("--crop") && !o.dataset.empty()) o.opt.crop = -1;  // (without --dataset: its 128 crops)
    // And the resolution pyramid (optim/view_pyramid.h), for both stages: the first
    // three quarters on views reduced to at most kBudgetCoarsePixels.
    if (!cmd.count("--coarse-pixels")) o.opt.coarse_pixels = kBudgetCoarsePixels;
    o.plan_fit_fine_fraction = !cmd.count("--fine-fraction");  // full resolution first (fit_stage.h)
  }
  const double fit_seconds = budget.budget_s > 0.0 ? kFitShare * (budget.budget_s - budget.spent_s) : 0.0;
  if (!o.dataset.empty() && !o.estimate && comm.size() == 1) capture_stage(o);
  if (o.dataset.empty()) {
    if (const int rc = radiance_stage(o, cmd, comm)) return rc;
  } else if (const int rc = geometry_stage(o, comm, fit_seconds)) {
    return rc;
  }
  // Bounce light from the splats' captured radiance where the geometry stage has
  // just fitted their SH to these photos (field_radiance.h); else path-traced. A
  // resumed run goes on as it began (its checkpoint names `field`; older ones
  // and path-traced runs do not).
  const std::string ckpt = (std::filesystem::path(o.out) / "checkpoint.bin").string();
  std::error_code ec;
  const bool resuming = o.resume && std::filesystem::exists(ckpt, ec);
  const std::vector<std::pair<std::string, std::string>> resumed =
      resuming ? read_checkpoint(ckpt).fingerprint : std::vector<std::pair<std::string, std::string>>();
  if (o.opt.indirect == "auto") {
    o.opt.indirect = resuming ? "path" : o.fitted ? "field" : "path";
    for (const auto& kv : resumed)
      if (kv.first == "indirect") o.opt.indirect = kv.second;
  }
  // The loss space a resumed run began with, unless --loss-space is given (checkpoints
  // from before srgb-blur-first became the default compared in plain srgb).
  if (resuming && cmd.count("--loss-space") == 0)
    for (const auto& kv : resumed)
      if (kv.first == "loss")
        for (const char* space : {"srgb-blur-first", "srgb", "linear"})
          if ((" " + kv.second + " ").find(std::string(" ") + space + " ") != std::string::npos) {
            o.opt.loss_space = space;
            break;
          }
  std::shared_ptr<const Dataset> data;
  std::unique_ptr<Optimizer> optimizer = make_optimizer(o, cmd, &data);
  Optimizer& opt = *optimizer;
  if (o.estimate) {  // with a budget: the inversion's share of it (a geometry stage would take up to kFitShare)
    const int rc = comm.rank() == 0 ? print_estimate(opt, t_start,
                                                     budget.budget_s * (o.fit_iters > 0 && !o.dataset.empty() ? 1.0 - kFitShare : 1.0),
                                                     o.targets_left_s)
                                    : 0;
    comm.barrier();  // every rank done with the scratch folder before it goes
    return rc;
  }
  if (budget.budget_s > 0.0) budget = plan_optimizer_budget(opt, budget, t_start, o.quiet);
  opt.set_communicator(comm);
  if (!o.quiet)
    std::fprintf(stderr,
                 "optimize: %zu Gaussians, %zu %s views %dx%d%s, %d iterations, %d spp, %d bounces (indirect: %s), loss %s, env %s, "
                 "seed %llu\n",
                 opt.scene().gaussians->size(), data->size(), data->split.c_str(), data->width, data->height,
                 data->has_priors() ? " (with priors)" : "", opt.settings().iterations, opt.settings().integrator.spp, o.opt.bounces, o.opt.indirect.c_str(),
                 o.opt.loss_space.c_str(),
                 o.opt.env.c_str(),
                 (unsigned long long)o.opt.seed);
  if (!o.quiet && comm.size() > 1)
    std::fprintf(stderr, "optimize: %d MPI ranks, each view split in row bands across them\n", comm.size());
  if (!o.quiet && budget.budget_s == 0.0 && opt.iteration() < opt.settings().iterations) {  // measured on a probe window (iteration_estimate.h)
    const IterationEstimate est = estimate_iteration(opt);
    std::fprintf(stderr, "optimize: estimated %.2f s/iter, %s for %d iterations (probe %d pixels at %d spp: %.2f + %.2f us per "
                 "path sample, primal + replay; regulariser %.2f us per pixel)\n", est.seconds,
                 duration_text(est.seconds * (opt.settings().iterations - opt.iteration())).c_str(),
                 opt.settings().iterations - opt.iteration(), est.probe_pixels, est.probe_spp,
                 1e6 * est.primal_per_sample, 1e6 * est.replay_per_sample, 1e6 * est.regulariser_per_pixel);
  }

  auto previous = install_sigint();
  const int start_it = opt.iteration();
  const auto t0 = std::chrono::steady_clock::now();
  RunOptions ro;
  ro.out_dir = comm.rank() == 0 ? o.out : "";
  ro.checkpoint_every = o.checkpoint_every;
  ro.cancel = &g_interrupted;
  int saved = o.resume ? start_it : -1;  // the iteration OUT/checkpoint.bin holds (data-parallel stop line)
  if (comm.size() > 1) {
    ro.cancel = nullptr;  // no rank may stop alone mid-iteration (job_stop.h)
    std::signal(SIGINT, previous);
    install_job_stop_handlers(comm.rank() == 0);
    set_job_stop_message(stop_message(ckpt, start_it, saved));
  }
  const BudgetPacer pacer(budget.budget_s - budget.spent_s - kOutputReserve);
  PhaseClock phases;  // the resolution pyramid's two phases, timed apart
  auto last = t0;
  ro.on_iteration = [&](const IterationLog& l) {
    if (budget.budget_s > 0.0) {  // re-plan the count from the measured rate; OUT/budget.json for --resume
      const auto now = std::chrono::steady_clock::now();
      const double since_start = std::chrono::duration<double>(now - t_start).count();
      phases.add(l.level, std::chrono::duration<double>(now - last).count());
      last = now;
      const int total = opt.pyramid_coarse_share() > 0.0
                            ? pacer.replan(opt.iteration(), since_start, opt.settings().iterations,
                                           phases.costs(opt.pyramid_coarse_share(),
                                                        budget.est_coarse_s > 0.0 ? budget.est_fine_s / budget.est_coarse_s : 1.0))
                            : pacer.replan(opt.iteration(), opt.iteration() - start_it,
                                           std::chrono::duration<double>(now - t0).count(), since_start,
                                           opt.settings().iterations);
      if (total != opt.settings().iterations) opt.set_iterations(total);
      BudgetState b = budget;
      b.spent_s += since_start;
      write_budget_state(o.out, b);
    }
    if (comm.size() > 1) {
      // run_optimizer has saved the checkpoint of the previous iteration by now.
      const int prev = opt.iteration() - 1;
      if (o.checkpoint_every > 0 && prev > start_it && prev % o.checkpoint_every == 0) saved = prev;
      set_job_stop_message(stop_message(ckpt, opt.iteration(), saved));
    }
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
  const RunResult r = with_sigint_restored(previous, [&] { return run_optimizer(opt, ro); });
  if (o.plan) o.plan->commit();  // the results are the new plan's: it goes in place with them
  if (opt.nonfinite_gradients() > 0 && !o.quiet)
    std::fprintf(stderr, "warning: %zu non-finite gradient entries were dropped\n", opt.nonfinite_gradients());
  if (r == RunResult::Cancelled) {
    std::fprintf(stderr, "ptir: interrupted after iteration %d; wrote %s and the outputs in %s (continue with --resume)\n",
                 opt.iteration(), ckpt.c_str(), o.out.c_str());
    return 130;
  }
  if (o.env_detail && comm.rank() == 0) write_env_with_detail(o.out);
  if (!o.quiet)
    std::fprintf(stderr, "wrote %s/gaussians.ply, env.exr, log.csv (%d iterations)\n", o.out.c_str(), opt.iteration());
  return 0;
}

}  // namespace

Runner add_optimize_command(CLI::App& app) {
  auto o = std::make_shared<OptimizeCommand>();
  o->opt.env = "auto";  // resolved from the dataset's layout (resolve_dataset_defaults)
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
                  "geometry; skipped with --scene meshes and under MPI)")
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
                  "environment model: latlong (texels), sg (24 spherical Gaussians) or color (one constant colour); "
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
  cmd->add_option("--seed", o->opt.seed, "random seed (views, crops, paths)")->capture_default_str();
  cli::add_brdf_option(cmd, &o->brdf);
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
  cmd->add_option("--loss-space", o->opt.loss_space, "compare images in srgb-blur-first (the sRGB of the render after the loss's 3x3 blur, not before: its noise biases the loss 7x less), srgb (the sRGB of each pixel, then the blur) or linear space; a resumed run keeps its own")->capture_default_str();
  cmd->add_option("--lambda-tv", o->opt.lambda_tv, "weight of the edge-aware TV regulariser")->capture_default_str();
  cmd->add_option("--lr-final", o->opt.lr_final,
                  "learning rate at the last iteration, as a fraction of the initial one (1: constant)")
      ->capture_default_str();
  cmd->add_option("--lr-decay-start", o->opt.lr_decay_start,
                  "fraction of the iterations after which the learning rate decays (exponentially)")
      ->capture_default_str();
  cmd->add_option("--sample-cache-mb", o->opt.sample_cache_mb,
                  "memory for what each sample's replay reuses from its primal (radiance, ray outcomes, walks); "
                  "beyond it the replay traces again (same results)")
      ->capture_default_str();
  cmd->add_option("--env-coarse", o->opt.env_coarse,
                  "lat-long environment: width of a coarse level learnt with the texels (coarse-to-fine; 0: none; -1: 1/8 of the map's width)")
      ->capture_default_str();
  cmd->add_option("--albedo-warmup", o->opt.albedo_warmup,
                  "fraction of the iterations over which the albedo learning rates ramp up from 0 (light first)")
      ->capture_default_str();
  cmd->add_option("--tv-warmup", o->opt.tv_warmup,
                  "the TV weight starts at this multiple of --lambda-tv and falls to it at half the iterations")
      ->capture_default_str();
  cmd->add_option("--init-albedo", o->opt.init_albedo, "the Gaussians' starting albedo (linear, every channel)")
      ->capture_default_str();
  cmd->add_flag("--init-from-ply", o->opt.init_from_ply,
                "start albedo, roughness (and metallic) from the input PLY's albedo_*, roughness, metallic "
                "(a previous result to refine); without them the defaults apply");
  cmd->add_option("--light-balance", o->opt.light_balance,
                  "learn the light-albedo balance: one scale per channel moving all albedos against the environment (lat-long)")
      ->capture_default_str();
  cmd->add_option("--decorrelate-adjoint", o->opt.decorrelate_adjoint,
                  "weight each half of the samples' gradient by the image loss of the other, independent half (unbiased by the render's noise)")
      ->capture_default_str();
  cmd->add_option("--lambda-ssim", o->opt.lambda_ssim, "D-SSIM's weight in the image loss ((1 - w) L1 + w (1 - SSIM))")
      ->capture_default_str();
  cmd->add_option("--loss-blur", o->opt.loss_blur, "blur the render by a 3x3 binomial filter before the image loss (PTIR's noise suppression)")
      ->capture_default_str();
  cmd->add_option("--loss-blur-target", o->opt.loss_blur_target,
                  "with --loss-blur: blur the target image the same way (the optimum is then the unblurred match)")
      ->capture_default_str();
  cmd->add_option("--lr-balance", o->opt.lr_balance, "the light-albedo balance's Adam learning rate")->capture_default_str();
  cmd->add_option("--lambda-albedo-grey", o->opt.lambda_albedo_grey,
                  "grey-world prior on the albedos' mean colour, along the light-albedo balance only (0: off)")
      ->capture_default_str();
  cmd->add_option("--balance-start", o->opt.balance_start, "fraction of the iterations before the light-albedo balance learns")
      ->capture_default_str();
  cmd->add_option("--lr-env", o->opt.lr_env, "the environment's Adam learning rate (its log radiance per step)")
      ->capture_default_str();
  cmd->add_option("--lr-albedo", o->opt.lr_albedo, "the Gaussians' albedo Adam learning rate (logit per step)")
      ->capture_default_str();
  cmd->add_option("--lr-metallic", o->opt.lr_metallic,
                  "the Gaussians' metallic Adam learning rate (logit per step; with --optimize-metallic)")
      ->capture_default_str();
  cmd->add_option("--lr-roughness", o->opt.lr_roughness, "the Gaussians' roughness Adam learning rate (logit per step)")
      ->capture_default_str();
  cmd->add_option("--env-fine-rate", o->opt.env_fine_rate,
                  "with a coarse level: the fine texels' rate as a fraction of --lr-env (the coarse level's)")
      ->capture_default_str();
  cmd->add_option("--neutral-light", o->opt.neutral_light,
                  "keep the learnt environment's colour neutral, its colour going into the albedos (default: on "
                  "without --dataset, where baked radiance fixes only albedo x light; off with photos)");
  cmd->add_flag("--optimize-metallic", o->opt.optimize_metallic, "also optimise metallic (default: fixed 0)");
  cmd->add_flag("--optimize-meshes", o->opt.optimize_meshes, "also optimise the --scene meshes' materials");
  cmd->add_flag("--learn-exposure", o->opt.learn_exposure,
                "learn one exposure scale per training image (photos without EXIF exposure); OUT/exposure.json");
  cmd->add_flag("-q,--quiet", o->quiet, "no progress output");
  cmd->add_option("--budget", o->budget,
                  "time budget for the whole run instead of --iters, e.g. 90s, 10m, 1.5h: spp and iterations are planned "
                  "from the measured cost and the count re-planned as it runs (--resume continues it)");
  cmd->add_flag("--estimate", o->estimate,
                "print the estimated duration (one JSON line: setup_s, s_per_iter, total_s) and exit without optimising");
  add_force_flag(cmd, o->force);
  add_capture_flags(cmd, &o->capture);
  add_filter_flags(cmd, &o->filter);
  add_radiance_flags(cmd, &o->radiance);
  show_common_options(cmd, kCommonOptions);
  return [o, cmd] {
    if (!resolve_dataset_defaults(*o)) return 2;
    return run_optimize(*o, *cmd);
  };
}

}  // namespace ptir::cli
