// `ptir optimize --budget 10m` (src/ptir/optim/budget_plan.h): the whole
// command -- loading, the geometry stage, the iterations and the outputs --
// ends within the budget. The geometry stage takes at most kFitShare of what is left once
// the capture is analysed (its iteration count re-planned from its measured rate), and
// is skipped when that is less than the analysis, one pass over the photos, took; the inversion
// plans its spp and iterations from the probe's estimate, then re-plans the
// iteration count after every iteration from its own rate.
//
// OUT/budget.json (atomic, after every iteration) holds the budget, the
// seconds spent and the planned spp (both phases'): `--resume` continues a budgeted run with
// what is left of it (a new --budget replaces the total), at the same spp.
// (budget.json without coarse_spp, from before it was planned: the coarse phase at spp.)
#pragma once

#include <chrono>
#include <string>

#include "ptir/optim/budget_plan.h"

namespace ptir {
class Optimizer;
}

namespace ptir::pipeline {

// The geometry stage's share of a budget, at most. Within it the stage plans its pyramid's
// fine fraction (fit_stage.h): full-resolution iterations first, since the inversion after a
// fit of 1500 iterations at full resolution lands 0.5 dB albedo higher than after the
// pyramid's quarter (docs/performance.md, "The geometry stage's share"). At 256² that fit
// takes about 110 s on 2 cores: a fifth of 5 minutes bought the quarter only.
constexpr double kFitShare = 0.4;
// A budget's resolution pyramid: views reduced to at most this many pixels for the
// first (1 - fine fraction) of both stages (docs/performance.md#time-to-quality).
constexpr int kBudgetCoarsePixels = 16384;
// Seconds kept for writing the outputs and the last checkpoint after the last iteration.
constexpr double kOutputReserve = 2.0;

struct BudgetState {
  double budget_s = 0.0;  // 0: no budget
  double spent_s = 0.0;   // by earlier runs of this output folder (resumed)
  int spp = 0;            // planned (0: not planned yet)
  int coarse_spp = 0;     // planned for the resolution pyramid's coarse phase (0: spp)
  int views = 0;          // planned patches per full-resolution iteration (0: the automatic batch's)
  double fine_share = 0.0;  // the resolution pyramid's full-resolution share the plan chose (0: the settings')
  // Not kept: the plan may choose that share (a budget without --fine-fraction, not resumed).
  bool choose_fine_share = false;
  // Not kept in budget.json: the probe's estimate of a coarse and a full-resolution
  // iteration (the resolution pyramid's phases), until the run measures its own.
  double est_coarse_s = 0.0, est_fine_s = 0.0;
};

// OUT/budget.json, or a zero state when there is none.
BudgetState read_budget_state(const std::string& out_dir);
void write_budget_state(const std::string& out_dir, const BudgetState& b);

// Plans the optimiser's spp and iterations for what is left of the budget at
// `now` (the command started at t_start); prints the plan unless quiet.
// Returns the state to keep (with the planned spp).
BudgetState plan_optimizer_budget(Optimizer& opt, BudgetState b, std::chrono::steady_clock::time_point t_start,
                                  bool quiet);

// --estimate: the inputs are loaded (setup timed from t_start), then the probe; one JSON line on stdout.
// With a budget (budget_s > 0): the plan for what is left of it after the set-up ("spp" is the planned one).
// extra_setup_s: set-up still to come (radiance targets not rendered yet). Returns 0.
int print_estimate(const Optimizer& opt, std::chrono::steady_clock::time_point t_start, double budget_s,
                   double extra_setup_s, bool choose_fine_share = false);

}  // namespace ptir::pipeline
