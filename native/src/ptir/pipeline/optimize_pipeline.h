// The optimise pipeline (docs/method.md §9): what `ptir optimize` runs, and the
// Python module's ptir.optimize_pipeline (python/bind_pipeline.cpp), from one set
// of options.
//
//   capture stage   real photos: the splat measured against them, OUT/capture/ (capture_stage.h)
//   geometry stage  `ptir fit` on the splats into OUT/fit/ (fit_stage.h; --fit-iters, 0: none)
//   or, without a dataset, the radiance stage: targets from the splats' own radiance (radiance_stage.h)
//   inversion       materials and environment (optim/optimizer.h): OUT/gaussians.ply, env.exr,
//                   log.csv, checkpoint.bin; --resume continues it bit for bit
//   budget          --budget plans the stages' share, spp and iterations (optimize_budget.h)
//
// The options keep the command line's names and defaults (cli/cmd_optimize.cpp
// documents each); messages name them as the command line spells them.
#pragma once

#include <string>

#include "ptir/core/communicator.h"
#include "ptir/optim/optimizer_setup.h"
#include "ptir/pipeline/capture_options.h"
#include "ptir/pipeline/filter_options.h"
#include "ptir/pipeline/given_options.h"
#include "ptir/pipeline/progress_printer.h"
#include "ptir/pipeline/radiance_stage.h"

namespace ptir::pipeline {

struct OptimizePipelineOptions {
  OptimizePipelineOptions() { opt.env = "auto"; }  // resolved from the dataset's layout
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
  std::string budget;     // --budget: a time budget for the whole run (optimize_budget.h)
  OptimizeOptions opt;
  FilterOptions filter;
  bool force = false;
  CaptureOptions capture;  // real captures (docs/dataset_format.md)
  int fit_iters = 1500;    // the geometry stage first (0: the splats' geometry as given)
  RadianceStage radiance;  // no --dataset: targets from the splats' own radiance (radiance_stage.h)
  std::string subject = "auto";  // --subject: a real capture's splat is an object or the scene (capture_stage.h)
  ProgressFormat progress_format = ProgressFormat::text;  // --progress: the progress lines as text or JSON
  GivenOptions given;  // the options given explicitly ("--iters", ...)
};

// Runs the pipeline on `comm` (rank 0 alone reports and writes). Returns the exit
// status of `ptir optimize`: 0 when it finished, 2 for a usage error (no
// --gaussians to be found; the message printed), 130 when Ctrl-C (or the progress
// callback) stopped it, with the checkpoint and the outputs written. Throws Error
// for bad input. `on_progress` (optional) receives every progress event as the
// JSON object --progress json prints and may return false to stop (as Ctrl-C).
int run_optimize_pipeline(const OptimizePipelineOptions& options, const Communicator& comm,
                          const ProgressCallback& on_progress = {});

}  // namespace ptir::pipeline
