// The optimise pipeline's stages and their order (optimize_pipeline.h).
//
// First the geometry stage (--fit-iters, `ptir fit` into OUT/fit/; 0: none; see
// geometry_stage below), then the inversion on the fitted splats (inversion_stage.cpp).
// Writes OUT/gaussians.ply (every input property + albedo_0..2, roughness,
// metallic, nx,ny,nz), OUT/env.exr (lat-long, Blender orientation like the
// inputs), OUT/log.csv and OUT/checkpoint.bin (every --checkpoint-every
// iterations and at the end), all atomically. --resume continues from
// OUT/checkpoint.bin exactly (bit-identical on the same thread count); only
// --iters may differ from the interrupted run. One progress line per iteration
// on stderr (progress_printer.h). Ctrl-C stops after the last completed
// iteration, writes the checkpoint and the outputs, and returns 130 (a second
// Ctrl-C kills at once).
//
// --budget (s, m or h) instead of --iters: the whole run ends within it
// (optimize_budget.h: spp and iterations planned from the estimate, the count
// re-planned from the measured rate; OUT/budget.json lets --resume continue it).
//
// Without a dataset (--gaussians alone) the targets are rendered from the splats'
// own radiance (radiance_stage.h, docs/relightable.md), with defaults of their
// own (400 iterations, 16 spp, 128 crops).
//
// --estimate loads everything, times the probe of optim/iteration_estimate.h and
// prints one JSON line on stdout instead of optimising (nothing is written):
//   {"estimate": {"setup_s": S, "s_per_iter": T, "iterations": N, "total_s": S + N*T, ...}}
// setup_s is what a real run spends before its first iteration (loading the
// dataset and Gaussians, building the BVH, the probe itself, which a real run
// also does): the add-on's Optimise panel shows total_s before starting.
// Without a dataset it renders the first radiance target only (into a temp
// folder: nothing is written in OUT) and counts that view's time for each other.
// One writer per --out (output_guard.h); never a dataset's folder.
//
// Under MPI (`mpirun -np N ptir optimize ...`, native/mpi/world.h) every rank
// takes every view of each iteration in row bands (optim/data_parallel.h); rank 0
// alone prints progress and writes the outputs, the log and the checkpoints, and
// --resume continues from the checkpoint with any N. A stop from outside ends the
// job at once with a line naming the last checkpoint (job_stop.h).
#include "ptir/pipeline/optimize_pipeline.h"

#include <tbb/global_control.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>

#include "ptir/core/error.h"
#include "ptir/optim/budget_plan.h"
#include "ptir/optim/checkpoint.h"
#include "ptir/pipeline/capture_stage.h"
#include "ptir/pipeline/fit_stage.h"
#include "ptir/pipeline/output_guard.h"
#include "ptir/pipeline/pipeline_run.h"
#include "ptir/pipeline/trained_fit.h"
#include "ptir/scene/dataset.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/scene_json.h"

namespace ptir::pipeline {

namespace {

// The capture stage's view of the run (the input splats, the calibration so far).
CaptureStage capture_stage_of(const PipelineRun& o) {
  CaptureStage c{o.dataset, o.gaussians, o.out, o.capture, CaptureAnalysisSettings{}, o.resume, o.quiet, o.progress};
  c.s.subject = o.subject;
  char extra = 0;
  if (std::sscanf(o.env_size.c_str(), "%dx%d%c", &c.s.env_width, &c.s.env_height, &extra) != 2 || c.s.env_width < 1 ||
      c.s.env_height < 1)
    throw Error("--env-size must be WIDTHxHEIGHT (e.g. 128x64), got '" + o.env_size + "'");
  return c;
}

// Real photos (capture_stage.h): the analysis' calibration applies to every stage, and
// an object's background seen directly starts the environment (unless --env-init).
void capture_stage(PipelineRun& o) {
  if (o.subject != "auto" && o.subject != "object" && o.subject != "scene")
    throw Error("--subject must be auto, object or scene, got '" + o.subject + "'");
  const CaptureStageResult r = run_capture_stage(capture_stage_of(o));
  if (o.opt.background_loss == "auto") o.opt.background_loss = r.background_env.empty() ? "off" : "on";
  if (r.calibration.empty()) return;
  o.capture.calibration = r.calibration;
  if (o.opt.env_init.empty() && !r.background_env.empty() && o.opt.env == "latlong") {
    // Its start, learnt from there: holding the seen texels (--fix-env-seen) measured 2 dB lower on the
    // dog's held-out object pixels (docs/captures.md: a wall and paper at infinity light it wrongly).
    o.opt.env_init = r.background_env;
    o.opt.env_align = "off";  // made from the photos: already theirs
    if (o.opt.env_seen == "auto") o.opt.env_seen = "coarse";  // the photos' detail kept, its change learnt smooth
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
bool resolve_dataset_defaults(OptimizePipelineOptions& o) {
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

// The geometry stage (docs/method.md §9, `ptir fit`) before the materials:
// the splats are fitted to the training views into OUT/fit/, and the inversion
// runs on OUT/fit/gaussians.ply. Skipped, with a note, where it cannot model the
// images: a --scene with meshes (walls and floors in the views, which the fit
// does not trace) and data-parallel runs (run `ptir fit` first there). With
// --resume: an inversion already under way (OUT/checkpoint.bin) keeps the fitted
// splats it started from; a fit that was stopped continues from its checkpoint.
// Returns 0, or 130 when Ctrl-C stopped the fit.
// fit_seconds: the stage's time under a budget (0: none); pass_seconds: what the capture's analysis,
// one pass over the photos, took here (0: none ran).
int geometry_stage(PipelineRun& o, const Communicator& comm, double fit_seconds, double pass_seconds) {
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
  const bool fit_resumes = o.resume && (fs::exists(fit_dir / "checkpoint.bin", ec) ||
                                        fs::exists(fit_dir / "recolour" / "checkpoint.bin", ec));
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
  // The stage reads and renders the photos several times (its two fits' set-up, the held-out check):
  // a share of the budget under one pass over them would overrun it and leave the inversion nothing.
  char short_budget[200];
  std::snprintf(short_budget, sizeof short_budget,
                "the budget leaves it %.0f s, less than one pass over the photos took (%.0f s): the input splats are "
                "kept (a larger --budget runs it)",
                fit_seconds, pass_seconds);
  if (fit_seconds > 0.0 && !fit_resumes && fit_seconds < pass_seconds) return skip(short_budget);
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
  f.s.coarse_pixels = o.opt.coarse_pixels;  // the run's resolution pyramid, for both stages
  f.s.fine_fraction = o.opt.fine_fraction;
  f.plan_fine_fraction = o.plan_fit_fine_fraction && fit_seconds > 0.0;
  f.capture = o.capture;
  f.progress = o.progress;
  remove_stale_outputs({f.out}, o.quiet);
  const CaptureStage check = capture_stage_of(o);
  if (trained_fit_applies(check)) {  // a trained splat on real photos: its colours first (trained_fit.h)
    const TrainedFitResult r = run_trained_fit_stage(f, check, "ptir optimize ... --resume");
    if (r.rc != 0) return r.rc;
    if (r.kept == "input") return 0;  // the input splats stay
  } else if (const int rc = run_fit_stage(f, "ptir optimize ... --resume"); rc != 0) {
    return rc;
  }
  o.gaussians = fitted;
  o.fitted = true;
  return 0;
}

// No dataset: the targets are rendered from the splats' own radiance into
// OUT/radiance/ (cached: a run stopped there re-uses them), which then is the
// dataset; no geometry stage (the targets are the splats' own). With SH degree 0
// the targets do not change with the view: roughness and metallic stay at their
// priors (their learning rates are 0), and the run says so.
int radiance_stage(PipelineRun& o, const Communicator& comm) {
  o.radiance.gaussians = o.gaussians;
  o.radiance.out = o.out;
  o.radiance.quiet = o.quiet || comm.rank() != 0;
  o.radiance.estimate = o.estimate;
  o.radiance.progress = o.progress;
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

// A time budget (optimize_budget.h): given, or kept by the run --resume continues.
// A budgeted run takes the automatic batch and the resolution pyramid where their
// options are not given.
BudgetState resolve_budget(PipelineRun& o, const Communicator& comm) {
  BudgetState budget;
  if (!o.budget.empty()) {
    if (o.given.count("--iters"))
      throw Error("give --iters or --budget, not both (--iters: a reproducible run; --budget: one that ends in time)");
    budget.budget_s = parse_duration(o.budget, "--budget");
  }
  bool budgeted = budget.budget_s > 0.0;  // (a budgeted run resumed with --iters keeps its batch)
  int kept_views = 0;                     // the patches a resumed budget planned
  if (o.resume && !o.estimate) {
    const BudgetState kept = read_budget_state(o.out);
    budgeted = budgeted || kept.budget_s > 0.0;
    if (kept.spp > 0 && !o.given.count("--spp")) o.opt.spp = kept.spp;  // the planned samples go on
    if (kept.spp > 0 && !o.given.count("--coarse-spp")) o.opt.coarse_spp = kept.coarse_spp;
    kept_views = kept.views > 0 && !o.given.count("--views-per-iter") ? kept.views : 0;
    if (kept.budget_s > 0.0 && !o.given.count("--iters")) {
      if (budget.budget_s == 0.0) budget.budget_s = kept.budget_s;
      budget.spent_s = kept.spent_s;
      budget.spp = kept.spp;
      budget.coarse_spp = kept.coarse_spp;
      budget.views = kept.views;
      budget.fine_share = kept.fine_share;
      if (kept.fine_share > 0.0 && !o.given.count("--fine-fraction")) o.inversion_fine_share = kept.fine_share;
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
    if (!o.given.count("--views-per-iter")) o.opt.views_per_iter = kept_views;  // 0: automatic
    if (!o.given.count("--crop") && !o.dataset.empty()) o.opt.crop = -1;  // (without a dataset: its 128 crops)
    // And the resolution pyramid (optim/view_pyramid.h), for both stages: the first
    // three quarters on views reduced to at most kBudgetCoarsePixels.
    if (!o.given.count("--coarse-pixels")) o.opt.coarse_pixels = kBudgetCoarsePixels;
    o.plan_fit_fine_fraction = !o.given.count("--fine-fraction");  // full resolution first (fit_stage.h)
    // The inversion's share, from the photos' pixels (budget_plan.h: data_fine_share), when it
    // plans afresh; a resumed plan keeps its own.
    budget.choose_fine_share = !o.given.count("--fine-fraction") && budget.spp == 0;
  }
  return budget;
}

// What a resumed run began with, unless given again: where indirect light comes
// from and the loss space.
void resumed_choices(PipelineRun& o) {
  // Bounce light from the splats' captured radiance where the geometry stage has
  // just fitted their SH to these photos (field_radiance.h); else path-traced. A
  // resumed run goes on as it began (its checkpoint names `field`; older ones
  // and path-traced runs do not).
  const std::string ckpt = (std::filesystem::path(o.out) / "checkpoint.bin").string();
  std::error_code ec;
  const bool resuming = o.resume && std::filesystem::exists(ckpt, ec);
  const Fingerprint resumed = resuming ? read_checkpoint(ckpt).fingerprint : Fingerprint();
  if (o.opt.indirect == "auto") {
    o.opt.indirect = resuming ? "path" : o.fitted ? "field" : "path";
    for (const auto& kv : resumed)
      if (kv.first == "indirect") o.opt.indirect = kv.second;
  }
  // The loss space a resumed run began with, unless --loss-space is given (checkpoints
  // from before srgb-blur-first became the default compared in plain srgb).
  if (resuming && o.given.count("--loss-space") == 0)
    for (const auto& kv : resumed)
      if (kv.first == "loss")
        for (const char* space : {"srgb-blur-first", "srgb", "linear"})
          if ((" " + kv.second + " ").find(std::string(" ") + space + " ") != std::string::npos) {
            o.opt.loss_space = space;
            break;
          }
}

// The stages in order, on rank 0's outputs (locked for the run).
int run_stages(PipelineRun& o, const Communicator& comm) {
  if (o.threads < 0) throw Error("--threads must be positive");
  std::optional<tbb::global_control> limit;
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
  if (o.dataset.empty()) apply_radiance_defaults(o.opt, o.given);  // first: a resumed budget's spp goes over them
  const BudgetState budget = resolve_budget(o, comm);
  using Clock = std::chrono::steady_clock;
  const Clock::time_point t_capture = Clock::now();
  if (!o.dataset.empty() && !o.estimate && comm.size() == 1) capture_stage(o);
  // The geometry stage's share of what the budget has left once the capture is analysed.
  const double pass_seconds = std::chrono::duration<double>(Clock::now() - t_capture).count();
  const double left = budget.budget_s - budget.spent_s - std::chrono::duration<double>(Clock::now() - o.t_start).count();
  const double fit_seconds = budget.budget_s > 0.0 ? kFitShare * std::max(1.0, left) : 0.0;
  if (o.dataset.empty()) {
    if (const int rc = radiance_stage(o, comm)) return rc;
  } else if (const int rc = geometry_stage(o, comm, fit_seconds, pass_seconds)) {
    return rc;
  }
  resumed_choices(o);
  return run_inversion_stage(o, comm, budget);
}

}  // namespace

int run_optimize_pipeline(const OptimizePipelineOptions& options, const Communicator& comm,
                          const ProgressCallback& on_progress) {
  OptimizePipelineOptions resolved = options;
  if (!resolve_dataset_defaults(resolved)) return 2;
  PipelineRun o(resolved);
  o.t_start = std::chrono::steady_clock::now();
  // Data-parallel runs (world.h): rank 0 alone reports and writes.
  if (comm.rank() != 0) o.quiet = true;
  o.progress = ProgressPrinter(o.progress_format, o.quiet, on_progress);
  try {
    return run_stages(o, comm);
  } catch (const Cancelled&) {
    throw;
  } catch (const std::exception& e) {
    o.progress.error(e.what());
    throw;
  }
}

}  // namespace ptir::pipeline
