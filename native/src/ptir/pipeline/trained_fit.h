// The geometry stage on a user's trained splat with real photos (`ptir optimize` and `ptir fit`
// on a capture the capture stage calibrated; docs/captures.md, "The user's splat is kept unless
// the photos prove a change better").
//
// A trained splat's colours are graded away from the photos, so a fit that refits them always
// "shows the photos better" than the input, whatever it did to the geometry. The change of
// geometry is judged against the same geometry with its colours refitted:
//   1. recolour: the input's geometry frozen (positions, shapes, opacities, the count), its SH
//      radiance refitted to the photos, into FIT_OUT/recolour/ (kRecolourShare of the stage);
//   2. refine: the whole fit from the recoloured splats, into FIT_OUT/ (the rest of the stage);
//   3. check: each of the input, the recoloured and the refined fields against the held-out
//      photos (optim/geometry_check.h); the best is FIT_OUT/gaussians.ply (the refined one then
//      FIT_OUT/refined.ply), or the input where it beats both; FIT_OUT/check.json and the
//      calibration's record ("geometry") say which and the three scores.
#pragma once

#include <string>

#include "ptir/pipeline/capture_stage.h"
#include "ptir/pipeline/fit_stage.h"

namespace ptir::pipeline {

// The stage's share that refits the colours only (its time, or its iterations without one).
constexpr double kRecolourShare = 0.5;

// Which splats the check kept ("input", "recoloured" or "fitted"; check.json's "kept").
struct TrainedFitResult {
  int rc = 0;  // 0, or 130 when Ctrl-C stopped it (the checkpoints written)
  std::string kept;
};

// Runs the three steps on f (f.out the stage's folder, f.s its settings for the refinement);
// `check` names the dataset, the input splats and the calibration. Resumes the step a stopped
// run was in (f.resume).
TrainedFitResult run_trained_fit_stage(const FitStage& f, const CaptureStage& check, const std::string& continue_hint);

// Whether the capture has held-out photos and a calibration, so that the check applies.
bool trained_fit_applies(const CaptureStage& c);

}  // namespace ptir::pipeline
