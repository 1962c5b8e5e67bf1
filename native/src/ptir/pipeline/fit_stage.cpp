#include "ptir/pipeline/fit_stage.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "ptir/pipeline/run_control.h"
#include "ptir/core/error.h"
#include "ptir/optim/budget_plan.h"
#include "ptir/optim/checkpoint.h"
#include "ptir/scene/dataset.h"
#include "ptir/scene/gaussian_ply.h"

namespace ptir::pipeline {

void check_fit_stage(const FitStage& f) {
  if (f.checkpoint_every < 0) throw Error("--checkpoint-every must be >= 0");
  if (f.s.iterations < 0) throw Error("--iters must be >= 0");
  if (f.s.densify_every < 1) throw Error("--densify-every must be >= 1");
  if (f.s.coarse_pixels < 0) throw Error("--coarse-pixels must be >= 0 (0: no resolution pyramid)");
  if (!(f.s.fine_fraction >= 0.0f && f.s.fine_fraction <= 1.0f)) throw Error("--fine-fraction must be in [0, 1]");
  if (f.s.accel.k < 1 || f.s.accel.k > SceneAccel::kMaxK) throw Error("--k must be in 1..64");
}

void freeze_geometry(FitStage& f) {
  f.s.lr_position = f.s.lr_scale = f.s.lr_rotation = f.s.lr_opacity = f.s.lr_normal = 0.0f;
  f.s.lambda_distortion = 0.0f;
  f.no_densify = true;
}

namespace {

constexpr int kPlanAfterCoarse = 8;  // coarse iterations timed before the fine fraction is planned

// The fine fraction a budgeted fit planned, from its checkpoint's fingerprint ("pyramid":
// "N until C", C the coarse share); `fallback` where it names none.
double planned_fine_fraction(const std::string& ckpt, double fallback) {
  std::error_code ec;
  if (!std::filesystem::exists(ckpt, ec)) return fallback;
  for (const auto& kv : read_checkpoint(ckpt).fingerprint) {
    if (kv.first != "pyramid") continue;
    const size_t at = kv.second.find(" until ");
    if (at == std::string::npos) throw Error(ckpt, "fingerprint 'pyramid' is not 'N until SHARE': " + kv.second);
    return 1.0 - double(std::stof(kv.second.substr(at + 7)));
  }
  return fallback;
}

}  // namespace

int run_fit_stage(const FitStage& f, const std::string& continue_hint) {
  check_fit_stage(f);
  DatasetOptions dopt;
  dopt.split = f.split;
  apply_capture_options(f.capture, dopt);
  std::shared_ptr<const Dataset> data = load_dataset(f.dataset, dopt);
  data->check_images();  // every photo decodes and fits its camera, before any iteration
  GeometryFitSettings s = f.s;
  s.max_gaussians = f.max_gaussians;
  const std::string ckpt = (std::filesystem::path(f.out) / "checkpoint.bin").string();
  if (f.resume && f.plan_fine_fraction) s.fine_fraction = planned_fine_fraction(ckpt, s.fine_fraction);
  if (f.no_densify) s.densify_every = 1 << 30;
  GeometryFit fit(load_gaussians(f.gaussians), data, s);
  if (f.resume) {
    std::error_code ec;
    if (!std::filesystem::exists(ckpt, ec)) throw Error(ckpt, "--resume: no checkpoint to continue from");
    fit.restore(read_checkpoint(ckpt), ckpt);
    if (!f.quiet) std::fprintf(stderr, "resumed from %s at iteration %d\n", ckpt.c_str(), fit.iteration());
  }
  if (!f.quiet)
    std::fprintf(stderr, "fit: %zu Gaussians (at most %zu), %zu %s views %dx%d, %d iterations, seed %llu\n",
                 fit.field().size(), fit.settings().max_gaussians, data->size(), data->split.c_str(), data->width,
                 data->height, s.iterations, (unsigned long long)s.seed);

  const ProgressPrinter progress = f.progress.quiet(f.quiet);
  const int start_it = fit.iteration();
  const auto t0 = std::chrono::steady_clock::now();
  FitRunOptions ro;
  ro.out_dir = f.out;
  ro.checkpoint_every = f.checkpoint_every;
  ro.cancel = &g_interrupted;
  const BudgetPacer pacer(f.seconds);
  PhaseClock phases;  // the resolution pyramid's phases, timed apart
  double last = 0.0;
  // A full-resolution iteration against a coarse one: the pixels' ratio on the render and
  // the replay, the BVH build unchanged (measured at 256²: 0.083 s against 0.027, where
  // the pixels alone say 4x). From the coarse iterations' own split.
  const double pixel_ratio = double(fit.coarse_factor()) * fit.coarse_factor();
  double coarse_s = 0.0, coarse_build_s = 0.0;
  int coarse_seen = 0;
  auto fine_over_coarse = [&] {
    if (coarse_s <= 0.0) return pixel_ratio;
    const double build = std::min(coarse_build_s, coarse_s) / coarse_s;
    return build + pixel_ratio * (1.0 - build);
  };
  bool plan_pending = f.plan_fine_fraction && f.seconds > 0.0 && fit.coarse_share() > 0.0 && start_it == 0;
  ro.on_iteration = [&](const FitLog& l) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    phases.add(l.level, elapsed - last);
    last = elapsed;
    if (l.level > 1 && ++coarse_seen > 2) coarse_s += l.seconds, coarse_build_s += l.build_s;
    if (plan_pending && coarse_seen >= kPlanAfterCoarse) {  // the first ones' costs, measured
      plan_pending = false;
      const PhaseCosts c = phases.costs(fit.coarse_share(), fine_over_coarse());
      const double ff = plan_fine_fraction(f.seconds - elapsed, fit.iteration(), fit.settings().iterations, c,
                                           fit.settings().fine_fraction);
      // On a grid of 1/1024, so the fingerprint's "until 1 - ff" reads back to the same float.
      fit.set_fine_fraction(float(std::floor(ff * 1024.0) / 1024.0));
      if (!f.quiet)
        std::fprintf(stderr, "fit: %.0f %% of the iterations at full resolution (%.3f s coarse, %.3f s full, estimated)\n",
                     100.0 * ff, c.coarse_s, c.fine_s);
    }
    if (f.seconds > 0.0) {  // a time limit (ptir optimize --budget): never more than the iterations asked for
      const int replanned = fit.coarse_share() > 0.0
                                ? pacer.replan(fit.iteration(), elapsed, fit.settings().iterations,
                                               phases.costs(fit.coarse_share(), fine_over_coarse()))
                                : pacer.replan(fit.iteration(), fit.iteration() - start_it, elapsed, elapsed,
                                               fit.settings().iterations);
      const int total = std::min(s.iterations, replanned);
      if (total != fit.settings().iterations) fit.set_iterations(total);
    }
    const int done = fit.iteration() - start_it;
    const double eta = (done > 0 ? elapsed / done : l.seconds) * double(fit.settings().iterations - fit.iteration());
    progress.fit_iteration(l, fit.settings().iterations, eta);
    return true;
  };
  auto previous = install_sigint();
  const RunResult r = with_sigint_restored(previous, [&] { return run_geometry_fit(fit, ro); });
  progress.done("fit", r != RunResult::Cancelled, fit.iteration(), f.out);
  if (r == RunResult::Cancelled) {
    std::fprintf(stderr, "ptir: interrupted after iteration %d; wrote %s and the outputs in %s (continue with %s)\n",
                 fit.iteration(), ckpt.c_str(), f.out.c_str(), continue_hint.c_str());
    return 130;
  }
  if (!f.quiet)
    std::fprintf(stderr, "wrote %s/gaussians.ply (%zu Gaussians), log.csv (%d iterations)\n", f.out.c_str(),
                 fit.field().size(), fit.iteration());
  return 0;
}

}  // namespace ptir::pipeline
