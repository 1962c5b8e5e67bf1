// `ptir fit`: the geometry stage (src/ptir/optim/geometry_fit.h) -- fit imported
// splats to posed images through our own ray-traced compositing and learn their
// shading normals, before the material inversion (`ptir optimize`).
//
//   ptir fit --dataset DIR --gaussians IN.ply --out OUT [--iters N] [--seed S] [--resume]
//       [--checkpoint-every N] [--threads N] [--lambda-normal X] [--lambda-mask X]
//       [--normal-from N] [--normal-per-hit] [--normal-outlier-deg D] [--reorient-every N]
//       [--lambda-distortion X] [--distortion-from N]
//       [--max-gaussians N] [--no-densify] [--k K] [-q] [capture flags]
//
// Writes OUT/gaussians.ply (standard 3DGS layout with the fitted values, SH
// radiance, nx,ny,nz; material columns as the writer adds them), OUT/log.csv and
// OUT/checkpoint.bin, atomically. --resume, Ctrl-C (exit 130 after writing the
// checkpoint) and the progress lines work as for `ptir optimize`.
#include <tbb/global_control.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include "capture_flags.h"
#include "commands.h"
#include "output_guard.h"
#include "run_control.h"
#include "ptir/core/error.h"
#include "ptir/optim/geometry_fit.h"
#include "ptir/scene/dataset.h"
#include "ptir/scene/gaussian_ply.h"

namespace ptir::cli {

namespace {

struct FitCommand {
  std::string dataset, gaussians, out, split = "train";
  bool resume = false, quiet = false, force = false, no_densify = false;
  int checkpoint_every = 200, threads = 0;
  size_t max_gaussians = 0;
  GeometryFitSettings s;
  CaptureFlags capture;
};

int run_fit(FitCommand& o) {
  std::optional<tbb::global_control> limit;
  if (o.threads < 0) throw Error("--threads must be positive");
  if (o.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(o.threads));
  if (o.checkpoint_every < 0) throw Error("--checkpoint-every must be >= 0");
  if (o.s.iterations < 0) throw Error("--iters must be >= 0");
  if (o.s.densify_every < 1) throw Error("--densify-every must be >= 1");
  if (o.s.accel.k < 1 || o.s.accel.k > SceneAccel::kMaxK) throw Error("--k must be in 1..64");
  guard_outputs({{o.gaussians}, {o.dataset}, {}}, {{}, {o.out}}, o.force);
  remove_stale_outputs({o.out}, o.quiet);
  DatasetOptions dopt;
  dopt.split = o.split;
  apply_capture_flags(o.capture, dopt);
  std::shared_ptr<const Dataset> data = load_dataset(o.dataset, dopt);
  GeometryFitSettings s = o.s;
  s.max_gaussians = o.max_gaussians;
  if (o.no_densify) s.densify_every = 1 << 30;
  GeometryFit fit(load_gaussians(o.gaussians), data, s);
  const std::string ckpt = (std::filesystem::path(o.out) / "checkpoint.bin").string();
  if (o.resume) {
    std::error_code ec;
    if (!std::filesystem::exists(ckpt, ec)) throw Error(ckpt, "--resume: no checkpoint to continue from");
    fit.restore(read_checkpoint(ckpt), ckpt);
    if (!o.quiet) std::fprintf(stderr, "resumed from %s at iteration %d\n", ckpt.c_str(), fit.iteration());
  }
  if (!o.quiet)
    std::fprintf(stderr, "fit: %zu Gaussians (at most %zu), %zu %s views %dx%d, %d iterations, seed %llu\n",
                 fit.field().size(), fit.settings().max_gaussians, data->size(), data->split.c_str(), data->width,
                 data->height, s.iterations, (unsigned long long)s.seed);

  const int start_it = fit.iteration();
  const auto t0 = std::chrono::steady_clock::now();
  FitRunOptions ro;
  ro.out_dir = o.out;
  ro.checkpoint_every = o.checkpoint_every;
  ro.cancel = &g_interrupted;
  ro.on_iteration = [&](const FitLog& l) {
    if (o.quiet) return true;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const int done = fit.iteration() - start_it;
    const double eta = (done > 0 ? elapsed / done : l.seconds) * double(fit.settings().iterations - fit.iteration());
    std::fprintf(stderr, "iter %d/%d  loss %.5f (image %.5f mask %.5f normal %.5f)  %zu Gaussians", l.iteration,
                 fit.settings().iterations, l.loss, l.image, l.mask, l.normal, l.gaussians);
    if (l.pruned || l.cloned || l.split) std::fprintf(stderr, " (-%d +%d clones +%d splits)", l.pruned, l.cloned, l.split);
    if (l.flipped) std::fprintf(stderr, " (%d normals re-oriented)", l.flipped);
    std::fprintf(stderr, "  %.2f s/iter  ETA %s\n", l.seconds, duration_text(eta).c_str());
    return true;
  };
  auto previous = install_sigint();
  const RunResult r = with_sigint_restored(previous, [&] { return run_geometry_fit(fit, ro); });
  if (r == RunResult::Cancelled) {
    std::fprintf(stderr, "ptir: interrupted after iteration %d; wrote %s and the outputs in %s (continue with --resume)\n",
                 fit.iteration(), ckpt.c_str(), o.out.c_str());
    return 130;
  }
  if (!o.quiet)
    std::fprintf(stderr, "wrote %s/gaussians.ply (%zu Gaussians), log.csv (%d iterations)\n", o.out.c_str(),
                 fit.field().size(), fit.iteration());
  return 0;
}

}  // namespace

Runner add_fit_command(CLI::App& app) {
  auto o = std::make_shared<FitCommand>();
  CLI::App* cmd = app.add_subcommand("fit", "Fit imported splats to posed images by ray tracing and learn shading normals");
  cmd->add_option("--dataset", o->dataset, "dataset folder (the layouts of ptir optimize; docs/dataset_format.md)")
      ->required();
  cmd->add_option("--gaussians", o->gaussians, "input 3DGS .ply")->required();
  cmd->add_option("--out", o->out, "output folder")->required();
  cmd->add_option("--iters", o->s.iterations, "iterations")->capture_default_str();
  cmd->add_option("--seed", o->s.seed, "random seed (views, splits)")->capture_default_str();
  cmd->add_flag("--resume", o->resume, "continue from OUT/checkpoint.bin");
  cmd->add_option("--split", o->split, "dataset split")->capture_default_str();
  cmd->add_option("--checkpoint-every", o->checkpoint_every, "iterations between checkpoints (0: only at the end)")
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "limit worker threads (0: all)");
  cmd->add_option("--lambda-normal", o->s.lambda_normal, "weight of the pseudo-normal term")->capture_default_str();
  cmd->add_option("--normal-from", o->s.normal_from, "iteration from which the pseudo-normal term applies")
      ->capture_default_str();
  cmd->add_option("--normal-radius", o->s.normal_radius, "stencil radius (pixels) of the depth pseudo-normals")
      ->capture_default_str();
  cmd->add_flag("!--mean-depth", o->s.median_depth, "pseudo-normals from the mean depth (default: the median depth)");
  cmd->add_option("--normal-outlier-deg", o->s.normal_outlier_deg,
                  "supervise only pixels whose normal is this far (degrees) from the pseudo-normal (0: all)")
      ->capture_default_str();
  cmd->add_flag("--normal-per-hit", o->s.normal_per_hit, "per-hit normal loss weighted by the compositing weights");
  cmd->add_flag("--normal-to-weights", o->s.normal_to_weights, "let the normal term move the splats too");
  cmd->add_option("--lambda-distortion", o->s.lambda_distortion,
                  "weight of the depth-distortion term (gathers each ray's weights at one depth)")
      ->capture_default_str();
  cmd->add_option("--distortion-from", o->s.distortion_from, "iteration from which the depth-distortion term applies")
      ->capture_default_str();
  cmd->add_option("--lr-normal", o->s.lr_normal, "shading-normal learning rate")->capture_default_str();
  cmd->add_option("--lambda-mask", o->s.lambda_mask, "weight of |opacity - mask| where the images have alpha")
      ->capture_default_str();
  cmd->add_option("--lr-position", o->s.lr_position, "position learning rate (times the cameras' extent)")
      ->capture_default_str();
  cmd->add_option("--densify-grad", o->s.densify_grad, "mean positional gradient (3DGS units) that densifies")
      ->capture_default_str();
  cmd->add_option("--densify-every", o->s.densify_every, "iterations between densification steps")->capture_default_str();
  cmd->add_option("--densify-from", o->s.densify_from, "first densification iteration")->capture_default_str();
  cmd->add_option("--densify-until", o->s.densify_until, "no densification from this iteration on")
      ->capture_default_str();
  cmd->add_option("--max-gaussians", o->max_gaussians, "upper bound on the count (0: 1.5 x the input's)");
  cmd->add_flag("--no-densify", o->no_densify, "keep the count (no pruning, cloning or splitting)");
  cmd->add_option("--reorient-every", o->s.reorient_every,
                  "re-orient the normals toward the cameras every N iterations and after the last (0: never)")
      ->capture_default_str();
  cmd->add_option("--k", o->s.accel.k, "k-buffer size of the tracer")->capture_default_str();
  cmd->add_flag("-q,--quiet", o->quiet, "no progress output");
  add_force_flag(cmd, o->force);
  add_capture_flags(cmd, &o->capture);
  return [o] { return run_fit(*o); };
}

}  // namespace ptir::cli
