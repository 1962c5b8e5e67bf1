// Real photos before any fitting (`ptir optimize --dataset CAPTURE`; docs/captures.md,
// "Real photos"): the capture analysis (src/ptir/optim/capture_analysis.h) of the
// user's splat against every photo, into OUT/capture/ (calibration.json, masks/,
// background_env.exr); the geometry stage's check against the held-out photos is
// trained_fit.h's.
#pragma once

#include <string>

#include "ptir/pipeline/capture_options.h"
#include "ptir/pipeline/progress_printer.h"
#include "ptir/optim/capture_analysis.h"

namespace ptir::pipeline {

struct CaptureStage {
  std::string dataset, gaussians, out;
  CaptureOptions capture;
  CaptureAnalysisSettings s;
  bool resume = false, quiet = false;
  ProgressPrinter progress;  // the subject found (an event; its text is the analysis' lines)
};

struct CaptureStageResult {
  std::string calibration;     // OUT/capture/calibration.json ("" where none applies)
  std::string background_env;  // OUT/capture/background_env.exr ("" for a scene)
};

// NeRF-style sets (rendered, masked) and captures with their own masks need none (they are read as
// they are); a resumed run reuses what its first
// run wrote. Prints the analysis' lines unless quiet.
CaptureStageResult run_capture_stage(const CaptureStage& c);

// Whether the check kept the input splats over FIT_DIR/gaussians.ply (FIT_DIR/check.json).
bool fit_kept_input(const std::string& fit_dir);

// OUT/env.exr, learnt from OUT/capture/background_env.exr, with the detail the photos
// saw (src/ptir/lights/env_detail.h), atomically; nothing where the capture has no
// seen background.
void write_env_with_detail(const std::string& out);

}  // namespace ptir::pipeline
