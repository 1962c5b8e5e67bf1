// The geometry stage as the commands run it: `ptir fit` on its own, and `ptir
// optimize` before the materials (--fit-iters; docs/method.md §9). Loads the
// dataset and the splats, fits them (src/ptir/optim/geometry_fit.h) and writes
// OUT/gaussians.ply, log.csv and checkpoint.bin atomically, with the progress
// lines, --resume and Ctrl-C of `ptir fit`.
#pragma once

#include <string>

#include "ptir/pipeline/capture_options.h"
#include "ptir/pipeline/progress_printer.h"
#include "ptir/optim/geometry_fit.h"

namespace ptir::pipeline {

struct FitStage {
  std::string dataset, gaussians, out, split = "train";
  bool resume = false;  // continue from OUT/checkpoint.bin (which must exist)
  bool quiet = false, no_densify = false;
  int checkpoint_every = 200;
  size_t max_gaussians = 0;  // 0: 1.5 x the input's count
  double seconds = 0.0;      // > 0: a time limit; the iteration count is re-planned from the measured rate
  // With a time limit and the resolution pyramid: after the first coarse iterations, the
  // fine fraction becomes the largest (at least s.fine_fraction) whose iterations still fit
  // in the time (budget_plan.h: plan_fine_fraction). A resumed fit keeps the planned one
  // (its checkpoint's fingerprint).
  bool plan_fine_fraction = false;
  GeometryFitSettings s;
  CaptureOptions capture;
  ProgressPrinter progress;  // the iteration lines (text or JSON; silent when quiet)
};

// Throws Error for a setting out of range.
void check_fit_stage(const FitStage& f);

// The geometry frozen (positions, shapes, opacities, normals, the count): only the SH radiance
// learns (`ptir fit --sh-only`; what a geometry can show of the photos).
void freeze_geometry(FitStage& f);

// Runs the stage: 0 when it finished, 130 when Ctrl-C stopped it (the
// checkpoint and the outputs are written; the message says how to continue,
// naming `continue_hint`, e.g. "ptir fit ... --resume"). Reports a "done" event.
int run_fit_stage(const FitStage& f, const std::string& continue_hint = "--resume");

}  // namespace ptir::pipeline
