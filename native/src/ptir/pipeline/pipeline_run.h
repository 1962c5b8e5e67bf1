// The optimise pipeline's state as its stages hand it on (optimize_pipeline.cpp
// runs the stages, inversion_stage.cpp the inversion): the options, as the
// stages resolve them, and what the stages found.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include "ptir/core/communicator.h"
#include "ptir/pipeline/optimize_budget.h"
#include "ptir/pipeline/optimize_pipeline.h"
#include "ptir/pipeline/progress_printer.h"
#include "ptir/pipeline/radiance_stage.h"

namespace ptir::pipeline {

struct PipelineRun : OptimizePipelineOptions {
  explicit PipelineRun(const OptimizePipelineOptions& o) : OptimizePipelineOptions(o) {}
  bool fitted = false;   // the inversion runs on splats its geometry stage fitted (OUT/fit/)
  bool plan_fit_fine_fraction = false;  // a budget without --fine-fraction: the stage plans its own (fit_stage.h)
  double inversion_fine_share = 0.0;    // a resumed budget's planned full-resolution share (0: the options')
  double targets_left_s = 0;  // --estimate without --dataset: the radiance targets still to render
  bool env_detail = false;  // the environment started from the photos' background: OUT/env.exr gets their detail
  std::shared_ptr<ScratchFolder> scratch;  // --estimate without --dataset: its probe target (outside OUT)
  std::shared_ptr<PendingPlan> plan;       // without --dataset: a new plan, committed with the results
  ProgressPrinter progress;                // rank 0's progress (silent elsewhere and with --quiet)
  std::chrono::steady_clock::time_point t_start;  // when the run began (a budget counts from there)
};

// The inversion on the stages' splats or targets: loads the inputs (resumed when
// asked), --estimate's line, the budget's plan, the iterations with their
// progress, the outputs. Returns 0, or 130 when stopped (the checkpoint and the
// outputs written).
int run_inversion_stage(PipelineRun& o, const Communicator& comm, BudgetState budget);

}  // namespace ptir::pipeline
