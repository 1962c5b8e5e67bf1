// A time budget for `ptir optimize --budget 10m` (issue 38): artists think in
// minutes, not iterations x spp.
//
// Before the first iteration, plan_budget turns the seconds left into
// iterations and samples per pixel from the measured cost of an iteration
// (iteration_estimate.h): it keeps kReferenceIterations and takes the most
// samples that still fit them, on a ladder of (resolution pyramid's coarse
// phase, full-resolution phase) spp from 8/8 to 128/128; it gives up
// iterations only below 8 spp. Measured at 256² (docs/performance.md, "The
// pyramid's samples"): 800 x 16/32 beats 533 x 32/32 at equal time by 0.36 dB
// albedo, 420 x 16 loses 1.4 dB to 800 x 8, 1600 x 8 loses 0.34 dB to it
// (longer runs drift, docs/inversion.md); at 128², without the pyramid, the
// same rule against the earlier one (32 spp kept for 200-800 iterations):
// docs/performance.md. Then the pacer re-plans the iteration
// count from the run's own measured rate after every iteration, so the run ends
// within the budget whatever the estimate's error (the schedules -- warm-up,
// decay, balance -- are fractions of the count, so they stretch with it).
#pragma once

#include <string>
#include <utility>

#include "ptir/optim/iteration_estimate.h"

namespace ptir {

// "90", "90s", "10m", "1.5h" -> seconds, between kMinBudgetSeconds and kMaxBudgetSeconds;
// throws Error naming `what` on anything else (a malformed number, hex, inf, nan, a
// duration out of the range: `1e-300s` would plan nothing, `1e9h` overflowed the count).
double parse_duration(const std::string& text, const std::string& what);
constexpr double kMinBudgetSeconds = 1.0;
constexpr double kMaxBudgetSeconds = 30.0 * 24.0 * 3600.0;  // 30 days

// The budget's arithmetic, checked: the whole iterations of `per_iteration` seconds that
// fit in `seconds`, 0 where none does (or either is not a positive finite number), at most
// kMaxBudgetIterations (far above any plan: 30 days at 0.26 s per iteration), so a count
// never overflows an int, nor does `done` plus it.
constexpr int kMaxBudgetIterations = 10000000;
int iterations_within(double seconds, double per_iteration);

constexpr int kReferenceIterations = 800;  // the default run's count (docs/method.md §6)
// The plan's ladder, cheapest first: (the pyramid's coarse phase's spp, the fine
// phase's spp); a run without the pyramid takes the fine spp.
struct SppRung {
  int coarse, fine;
};
constexpr SppRung kSppRungs[] = {{8, 8}, {16, 16}, {16, 32}, {32, 32}, {32, 64}, {64, 64}, {64, 128}, {128, 128}};
// A rung is taken where it gives at least this many iterations: an eighth short of
// kReferenceIterations costs nothing measured (776 x 16/32: 32.67 dB against 800's
// 32.63), where the rung below would spend the rest on iterations past 800, which
// lose (1600 x 8/8: -0.34 dB against 800 x 8/8).
constexpr int kRungIterations = kReferenceIterations * 7 / 8;

// The full-resolution phase on the automatic batch of patches (patch_batch.h): where the
// training views hold more pixels than the run's full-resolution phase would visit, a
// rung's samples above kPatchSpp buy more patches per iteration -- up to kMaxPatchViews,
// and up to as many as visit the data's pixels -- before they buy samples per pixel. A
// real capture has far more pixels than a run visits (the plush dog: 73 photos of
// 375,000 pixels, 27 million; a 10-minute run's fine phase 250 x 8 patches of 32²: 2
// million). Measured there, 1000 iterations from the same splats and coarse phase, then
// 32 patches x 8 spp against 8 x 32 spp: +0.29 dB on the held-out object, every photo up
// (+0.10 to +0.43), 6 % more time. On a 256² synthetic set of 24 views (1.6 million
// pixels, visited once by the fine phase at 8 patches) the same trade at --budget 4m was
// even (albedo -0.22, relight +0.01 dB): the spp ladder is kept there
// (docs/captures.md, "Pixels before samples").
constexpr int kPatchSpp = 8;
constexpr int kMaxPatchViews = 32;

// Where the photos hold more pixels than even kMaxPatchViews patches visit in the default
// full-resolution share (data_patch_views above it), a budget that may choose the resolution
// pyramid's share (no --fine-fraction given; the pipeline asks it for real photos only,
// pipeline/optimize_budget.cpp) runs its last kLargeDataFineShare at full resolution instead of
// the settings' quarter: fewer iterations, each of the later ones on the photos' own pixels.
// Measured on the plush dog (73 photos of 750x500, 134 patches' worth) at --budget 6m from the
// same splats: 22.17 / 22.44 dB (object / frame) against 21.93 / 22.37 with the quarter, every
// held-out photo up. On a rendered 512² set of 40 views (10.5 M pixels) it went the other way
// on the albedo: 28.66 against 28.91 dB (two seeds each; relight +0.07, NVS +0.13), and a 256²
// set favoured the quarter too (docs/captures.md, "Pixels before samples").
constexpr double kLargeDataFineShare = 0.5;

struct BudgetPlan {
  int iterations = 0;
  int spp = 0;
  int coarse_spp = 0;       // the resolution pyramid's coarse phase (0: no pyramid)
  int views = 0;            // the full-resolution phase's patches per iteration (0: the batch as set)
  double fine_share = 0.0;  // the pyramid's full-resolution share the plan chose (0: the settings')
  double s_per_iter = 0.0;  // estimated, at the planned spp
};

// The patches per full-resolution iteration at which kReferenceIterations' full-resolution
// phase visits as many pixels as the training views hold (1 and more: the data's).
int data_patch_views(const IterationEstimate& e);
// A rung's full-resolution samples spent on the batch: (spp, patches per iteration), the
// patches 0 where the estimate's batch is not the automatic one, or where its patches
// already visit the data's pixels (data_patch_views): the spp ladder as it was.
std::pair<int, int> spread_fine_samples(const IterationEstimate& e, int fine_spp);

// The pyramid's full-resolution share for the estimate's data: kLargeDataFineShare where the
// automatic batch's photos hold more than kMaxPatchViews patches' worth of pixels, else
// `share` (the settings'); never below `share`. (The caller decides whether the data are photos.)
double data_fine_share(const IterationEstimate& e, double share);

// The plan for `seconds` of iterations from the estimate of an iteration at `s`'s spp and batch;
// choose_fine_share: the plan may also set the pyramid's full-resolution share (data_fine_share).
BudgetPlan plan_budget(double seconds, const IterationEstimate& e, const OptimizerSettings& s,
                       bool choose_fine_share = false);

// Seconds per iteration at `spp`, from the estimate's per-sample and per-pixel costs
// (with the pyramid: the mean over its phases, the coarse one at coarse_spp, 0: spp;
// the full-resolution one with `views` patches, 0: the estimate's batch).
double iteration_seconds(const IterationEstimate& e, const OptimizerSettings& s, int spp, int coarse_spp = 0,
                         int views = 0);
// Seconds of one iteration of the pyramid's coarse (or full-resolution) phase at `spp`
// (full resolution: with `views` patches, 0: the estimate's batch; every cost of a patch
// -- its samples, its regulariser pixels, its replay call -- scales with their count).
double phase_seconds(const IterationEstimate& e, bool coarse, int spp, int views = 0);

// A run in two phases of different cost (the resolution pyramid, view_pyramid.h):
// iteration it of a total-iteration run is coarse while it < coarse_share x total.
struct PhaseCosts {
  double coarse_share = 0.0;  // 0: one phase (every iteration fine)
  double coarse_s = 0.0;      // seconds per coarse iteration
  double fine_s = 0.0;        // seconds per fine iteration
  // Seconds of iterations [done, total) of a total-iteration run.
  double seconds_left(int done, int total) const;
};

// A run's own iterations per pyramid phase, timed by the caller: seconds and count,
// each phase's first two left out (caches warm up).
class PhaseClock {
 public:
  // One iteration at reduction factor `level` (> 1: coarse), `wall_s` since the one before.
  void add(int level, double wall_s);
  // The phases' costs: each phase's measured seconds per iteration once it has three,
  // else the other's times fine_over_coarse (the estimate's ratio), else 0 (unknown).
  PhaseCosts costs(double coarse_share, double fine_over_coarse) const;

 private:
  double seconds_[2] = {0.0, 0.0};
  int count_[2] = {0, 0}, seen_[2] = {0, 0};
};

// The geometry stage's fine fraction under a time limit (ptir optimize --budget): the
// largest share of its `total` iterations at full resolution -- the pyramid's last ones --
// whose iterations [done, total) still fit in `seconds_left` at `costs`' coarse and fine
// seconds, at least `least` (where none fits, the pacer cuts the count instead). A fit at
// full resolution throughout beat the pyramid's quarter by 0.5 dB albedo at the inversion
// after it (docs/performance.md, "The geometry stage's share"), and the coarse phase is
// what the time has to buy back.
double plan_fine_fraction(double seconds_left, int done, int total, const PhaseCosts& costs, double least);

// Re-plans the iteration count during a run that must end `end_s` seconds
// after the pacer's clock started (the caller's seconds).
class BudgetPacer {
 public:
  explicit BudgetPacer(double end_s) : end_s_(end_s) {}
  // After `done` iterations, `done_here` of them in this process over `elapsed_s` of
  // iterating, at `now_s`: the total to run (>= done; `total` when within 1 %).
  int replan(int done, int done_here, double elapsed_s, double now_s, int total) const;
  // Two phases: the largest total whose remaining iterations fit in what is left at
  // `now_s` at the phases' costs (measured by the caller per phase); >= done,
  // `total` when within 1 %.
  int replan(int done, double now_s, int total, const PhaseCosts& costs) const;

 private:
  double end_s_;
};

}  // namespace ptir
