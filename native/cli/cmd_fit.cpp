// `ptir fit`: the geometry stage (src/ptir/optim/geometry_fit.h) -- fit imported
// splats to posed images through our own ray-traced compositing and learn their
// shading normals, before the material inversion (`ptir optimize`).
//
//   ptir fit --dataset DIR --gaussians IN.ply --out OUT [--iters N] [--seed S] [--resume]
//       [--checkpoint-every N] [--threads N] [--lambda-normal X] [--lambda-mask X]
//       [--normal-from N] [--normal-per-hit] [--normal-outlier-deg D] [--reorient-every N]
//       [--lambda-distortion X] [--distortion-from N]
//       [--max-gaussians N] [--no-densify] [--k K] [--budget 1m] [-q] [capture flags]
//
// --budget (s, m or h): at most --iters iterations, fewer where they would not end
// in time (the count re-planned from the measured rate; the add-on's time presets).
// It takes the resolution pyramid unless --coarse-pixels is given, and spends the
// time on full-resolution iterations first unless --fine-fraction is (fit_stage.h).
//
// Writes OUT/gaussians.ply (standard 3DGS layout with the fitted values, SH
// radiance, nx,ny,nz; material columns as the writer adds them), OUT/log.csv and
// OUT/checkpoint.bin, atomically. --resume, Ctrl-C (exit 130 after writing the
// checkpoint) and the progress lines work as for `ptir optimize`.
#include <tbb/global_control.h>

#include <memory>
#include <optional>

#include "capture_flags.h"
#include "commands.h"
#include "output_guard.h"
#include "pyramid_flags.h"
#include "ptir/core/error.h"
#include "ptir/optim/budget_plan.h"
#include "ptir/pipeline/capture_stage.h"
#include "ptir/pipeline/fit_stage.h"
#include "ptir/pipeline/trained_fit.h"
#include "ptir/pipeline/optimize_budget.h"

namespace ptir::cli {

namespace {

using pipeline::CaptureStage;
using pipeline::FitStage;

struct FitCommand {
  FitStage stage;
  std::string budget;
  bool force = false;
  int threads = 0;
  bool sh_only = false;  // --sh-only: the geometry frozen, the radiance refitted
  std::string progress = "text";  // --progress text|json (pipeline/progress_printer.h)
};

int run_fit(const FitCommand& o, const CLI::App& cmd) {
  std::optional<tbb::global_control> limit;
  if (o.threads < 0) throw Error("--threads must be positive");
  if (o.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(o.threads));
  FitStage stage = o.stage;
  if (!o.budget.empty()) {
    stage.seconds = parse_duration(o.budget, "--budget");
    // As `ptir optimize --budget`'s geometry stage (the add-on's time presets run this one):
    // the resolution pyramid, its fine fraction planned from the time (fit_stage.h).
    if (!cmd.count("--coarse-pixels")) stage.s.coarse_pixels = pipeline::kBudgetCoarsePixels;
    stage.plan_fine_fraction = !cmd.count("--fine-fraction");
  }
  if (o.sh_only) pipeline::freeze_geometry(stage);  // what this geometry can show of the photos
  pipeline::check_fit_stage(stage);
  stage.progress = pipeline::ProgressPrinter(pipeline::parse_progress_format(o.progress), stage.quiet);
  // A real capture's photos measured against the splats first (capture_stage.h; the add-on's
  // optimise flow runs this command as its geometry stage): an object's coverage masks them.
  const CaptureStage capture{stage.dataset, stage.gaussians, stage.out, stage.capture,
                             CaptureAnalysisSettings{}, stage.resume, stage.quiet, stage.progress};
  guard_outputs({{o.stage.gaussians}, {o.stage.dataset}, {}, {o.stage.dataset}}, {{}, {o.stage.out}}, o.force);
  guard_result_folder(o.stage.out, o.force);
  const auto lock = lock_output_folder(o.stage.out, "ptir fit");
  remove_stale_outputs({o.stage.out}, o.stage.quiet);
  if (!o.stage.dataset.empty()) {
    const pipeline::CaptureStageResult r = pipeline::run_capture_stage(capture);
    if (!r.calibration.empty()) stage.capture.calibration = r.calibration;
  }
  // A trained splat on real photos: its colours refitted first, a change of geometry kept only
  // where the held-out photos prove it better (pipeline/trained_fit.h).
  CaptureStage check = capture;
  check.capture = stage.capture;
  if (!o.sh_only && !stage.capture.calibration.empty() && pipeline::trained_fit_applies(check))
    return pipeline::run_trained_fit_stage(stage, check, "ptir fit ... --resume").rc;
  return pipeline::run_fit_stage(stage);
}

}  // namespace

Runner add_fit_command(CLI::App& app) {
  auto o = std::make_shared<FitCommand>();
  CLI::App* cmd = app.add_subcommand("fit", "Fit imported splats to posed images by ray tracing and learn shading normals");
  cmd->add_option("--dataset", o->stage.dataset, "dataset folder (the layouts of ptir optimize; docs/dataset_format.md)")
      ->required();
  cmd->add_option("--gaussians", o->stage.gaussians, "input 3DGS .ply")->required();
  cmd->add_option("--out", o->stage.out, "output folder")->required();
  cmd->add_option("--iters", o->stage.s.iterations, "iterations")->capture_default_str();
  cmd->add_option("--budget", o->budget, "time limit, e.g. 90s, 2m: at most --iters iterations, fewer where they would not end in time");
  cmd->add_option("--seed", o->stage.s.seed, "random seed (views, splits)")->capture_default_str();
  cmd->add_flag("--resume", o->stage.resume, "continue from OUT/checkpoint.bin");
  cmd->add_option("--split", o->stage.split, "dataset split")->capture_default_str();
  cmd->add_option("--checkpoint-every", o->stage.checkpoint_every, "iterations between checkpoints (0: only at the end)")
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "limit worker threads (0: all)");
  cmd->add_option("--lambda-normal", o->stage.s.lambda_normal, "weight of the pseudo-normal term")->capture_default_str();
  cmd->add_option("--normal-from", o->stage.s.normal_from, "iteration from which the pseudo-normal term applies")
      ->capture_default_str();
  cmd->add_option("--normal-radius", o->stage.s.normal_radius, "stencil radius (pixels) of the depth pseudo-normals")
      ->capture_default_str();
  cmd->add_flag("!--mean-depth", o->stage.s.median_depth, "pseudo-normals from the mean depth (default: the median depth)");
  cmd->add_option("--normal-outlier-deg", o->stage.s.normal_outlier_deg,
                  "supervise only pixels whose normal is this far (degrees) from the pseudo-normal (0: all)")
      ->capture_default_str();
  cmd->add_flag("--normal-per-hit", o->stage.s.normal_per_hit, "per-hit normal loss weighted by the compositing weights");
  cmd->add_flag("--normal-to-weights", o->stage.s.normal_to_weights, "let the normal term move the splats too");
  cmd->add_option("--lambda-distortion", o->stage.s.lambda_distortion,
                  "weight of the depth-distortion term (gathers each ray's weights at one depth)")
      ->capture_default_str();
  cmd->add_option("--distortion-from", o->stage.s.distortion_from, "iteration from which the depth-distortion term applies")
      ->capture_default_str();
  cmd->add_option("--lr-normal", o->stage.s.lr_normal, "shading-normal learning rate")->capture_default_str();
  cmd->add_option("--lambda-mask", o->stage.s.lambda_mask, "weight of |opacity - mask| where the images have alpha")
      ->capture_default_str();
  cmd->add_option("--lr-position", o->stage.s.lr_position, "position learning rate (times the cameras' extent)")
      ->capture_default_str();
  cmd->add_option("--densify-grad", o->stage.s.densify_grad, "mean positional gradient (3DGS units) that densifies")
      ->capture_default_str();
  add_pyramid_flags(cmd, &o->stage.s.coarse_pixels, &o->stage.s.fine_fraction);
  cmd->add_option("--densify-every", o->stage.s.densify_every, "iterations between densification steps")->capture_default_str();
  cmd->add_option("--densify-from", o->stage.s.densify_from, "first densification iteration")->capture_default_str();
  cmd->add_option("--densify-until", o->stage.s.densify_until, "no densification from this iteration on")
      ->capture_default_str();
  cmd->add_option("--max-gaussians", o->stage.max_gaussians, "upper bound on the count (0: 1.5 x the input's)");
  cmd->add_flag("--no-densify", o->stage.no_densify, "keep the count (no pruning, cloning or splitting)");
  cmd->add_flag("--sh-only", o->sh_only,
                "freeze the geometry (positions, shapes, opacities, normals, the count) and refit only the SH radiance: "
                "what this geometry can show of the photos (a real capture's reference, docs/captures.md)");
  cmd->add_option("--reorient-every", o->stage.s.reorient_every,
                  "re-orient the normals toward the cameras every N iterations and after the last (0: never)")
      ->capture_default_str();
  cmd->add_option("--k", o->stage.s.accel.k, "k-buffer size of the tracer")->capture_default_str();
  cmd->add_flag("-q,--quiet", o->stage.quiet, "no progress output");
  cmd->add_option("--progress", o->progress,
                  "progress lines on stderr: text, or json (one JSON object per line: docs/engine_protocol.md)")
      ->capture_default_str();
  add_force_flag(cmd, o->force);
  add_capture_flags(cmd, &o->stage.capture);
  return [o, cmd] {
    try {
      return run_fit(*o, *cmd);
    } catch (const Cancelled&) {
      throw;
    } catch (const std::exception& e) {  // the error line of --progress json (Ctrl-C is no error: 130)
      if (!o->stage.quiet && o->progress == "json") pipeline::ProgressPrinter(pipeline::ProgressFormat::json, false).error(e.what());
      throw;
    }
  };
}

}  // namespace ptir::cli
