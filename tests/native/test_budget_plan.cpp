// Time budgets and patch batches (optim/budget_plan.h, optim/patch_batch.h):
// durations parse with their units and refuse the rest; a plan fits its budget
// by its own cost model (iteration_seconds x iterations <= budget) and moves
// the spp the way the header says (on the automatic patches: patches first); the pacer's re-plan lands the run on its end
// time; a budgeted fit buys full-resolution iterations with its time; the automatic batch takes patches only where a view is larger than it.
#include <gtest/gtest.h>

#include <cmath>
#include <utility>

#include "ptir/core/error.h"
#include "ptir/optim/budget_plan.h"
#include "ptir/optim/patch_batch.h"

using namespace ptir;

TEST(BudgetPlan, DurationsParseWithUnits) {
  EXPECT_DOUBLE_EQ(parse_duration("90", "--budget"), 90.0);
  EXPECT_DOUBLE_EQ(parse_duration("90s", "--budget"), 90.0);
  EXPECT_DOUBLE_EQ(parse_duration("10m", "--budget"), 600.0);
  EXPECT_DOUBLE_EQ(parse_duration("1.5h", "--budget"), 5400.0);
  EXPECT_DOUBLE_EQ(parse_duration("1s", "--budget"), 1.0);
  EXPECT_DOUBLE_EQ(parse_duration("720h", "--budget"), 30.0 * 86400.0);
  // Issue 54: out of 1 s .. 30 days, hex, blanks (strtod took all three).
  for (const char* bad : {"", "m", "-3m", "0", "10 m", "10d", "nan", "inf", "1e9h", "2147483648s", "1e-300s", "0.5s",
                          "721h", "0x10", " 5m", "1e400"}) {
    try {
      parse_duration(bad, "--budget");
      FAIL() << "accepted '" << bad << "'";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("--budget"), std::string::npos) << e.what();
    }
  }
}

TEST(BudgetPlan, IterationCountsNeverOverflow) {
  EXPECT_EQ(iterations_within(10.0, 0.5), 20);
  EXPECT_EQ(iterations_within(-1.0, 0.5), 0);
  EXPECT_EQ(iterations_within(10.0, 0.0), 0);
  EXPECT_EQ(iterations_within(1e300, 1e-9), kMaxBudgetIterations);  // was int(2e308): INT_MIN, then 1 iteration
  EXPECT_EQ(iterations_within(30.0 * 86400.0, 1e-9), kMaxBudgetIterations);
  EXPECT_EQ(iterations_within(std::nan(""), 1.0), 0);
  // The plan and the pacer at a 30-day budget and a microsecond iteration: the cap, not a wrapped count.
  IterationEstimate e;
  e.seconds = 1e-6;
  OptimizerSettings s;
  EXPECT_EQ(plan_budget(30.0 * 86400.0, e, s).iterations, kMaxBudgetIterations);
  const BudgetPacer pacer(30.0 * 86400.0);
  EXPECT_EQ(pacer.replan(10, 10, 1e-5, 1.0, 100), kMaxBudgetIterations);
}

namespace {
// An estimate of 1 s per iteration at 32 spp, of which 0.1 s does not scale with the spp.
IterationEstimate one_second_estimate() {
  IterationEstimate e;
  e.seconds = 1.0;
  e.fixed_seconds = 0.1;
  return e;
}
}  // namespace

TEST(BudgetPlan, FitsTheBudgetAndMovesTheSamples) {
  OptimizerSettings s;  // 32 spp
  const IterationEstimate e = one_second_estimate();
  EXPECT_NEAR(iteration_seconds(e, s, 16), 0.1 + 0.9 * 0.5, 1e-12);
  // 500 s: 500 iterations at 32 spp, 909 at 16: the samples give way to the iterations.
  BudgetPlan p = plan_budget(500.0, e, s);
  EXPECT_EQ(p.spp, 16);
  EXPECT_EQ(p.coarse_spp, 0);  // no pyramid
  EXPECT_EQ(p.iterations, 909);
  // 60 s: 184 iterations at 8 spp, the ladder's foot: fewer iterations.
  p = plan_budget(60.0, e, s);
  EXPECT_EQ(p.spp, 8);
  EXPECT_LE(p.iterations * iteration_seconds(e, s, p.spp), 60.0 + 1e-9);
  EXPECT_EQ(p.iterations, 184);
  // 4000 s: more than kReferenceIterations at 32 spp; the samples grow while 700 still fit.
  p = plan_budget(4000.0, e, s);
  EXPECT_EQ(p.spp, 128);  // 0.1 + 4 x 0.9 = 3.7 s at 128 spp: 1081 iterations
  EXPECT_GE(p.iterations, kReferenceIterations);
  EXPECT_LE(p.iterations * p.s_per_iter, 4000.0 + 1e-9);
}

// With the resolution pyramid the plan keeps kReferenceIterations and moves the samples
// along kSppRungs: the coarse phase gives up its samples first.
TEST(BudgetPlan, PyramidKeepsTheIterationsAndPutsTheSamplesLate) {
  OptimizerSettings s;  // 32 spp
  IterationEstimate e;
  e.coarse_share = 0.75;
  e.coarse_spp = e.fine_spp = 32;
  e.coarse_seconds = 0.8, e.coarse_fixed_seconds = 0.0;  // a coarse iteration: 0.025 s per spp
  e.fine_seconds = 1.0, e.fine_fixed_seconds = 0.04;     // a fine one: 0.03 s per spp + 0.04
  EXPECT_NEAR(phase_seconds(e, true, 16), 0.4, 1e-12);
  EXPECT_NEAR(phase_seconds(e, false, 64), 0.04 + 2 * 0.96, 1e-12);
  EXPECT_NEAR(iteration_seconds(e, s, 32, 16), 0.75 * 0.4 + 0.25 * 1.0, 1e-12);
  // 800 x 32/32 costs 800 x 0.85 = 680 s; 800 x 16/32 costs 440 s, 800 x 16/16 320 s.
  BudgetPlan p = plan_budget(700.0, e, s);
  EXPECT_EQ(p.coarse_spp, 32);
  EXPECT_EQ(p.spp, 32);
  p = plan_budget(500.0, e, s);  // 800 x 32/32 does not fit: the coarse phase halves
  EXPECT_EQ(p.coarse_spp, 16);
  EXPECT_EQ(p.spp, 32);
  EXPECT_GE(p.iterations, kReferenceIterations);
  EXPECT_LE(p.iterations * p.s_per_iter, 500.0 + 1e-9);
  p = plan_budget(350.0, e, s);  // then the fine phase
  EXPECT_EQ(p.coarse_spp, 16);
  EXPECT_EQ(p.spp, 16);
  // 310 s: 720 iterations at 16/16, an eighth short of 800 at most: taken, rather than
  // 1409 at 8/8 (iterations past 800 lose).
  p = plan_budget(310.0, e, s);
  EXPECT_EQ(p.spp, 16);
  EXPECT_GE(p.iterations, kRungIterations);
  EXPECT_LT(p.iterations, kReferenceIterations);
  p = plan_budget(100.0, e, s);  // below the first rung: fewer iterations at 8 spp
  EXPECT_EQ(p.coarse_spp, 8);
  EXPECT_EQ(p.spp, 8);
  EXPECT_LT(p.iterations, kReferenceIterations);
  EXPECT_LE(p.iterations * p.s_per_iter, 100.0 + 1e-9);
  p = plan_budget(5000.0, e, s);  // long: the fine phase doubles first
  EXPECT_GE(p.iterations, kReferenceIterations);
  EXPECT_LE(p.iterations * p.s_per_iter, 5000.0 + 1e-9);
  EXPECT_GT(p.spp, 32);
}

// The pyramid's phases at 32 spp on the automatic batch of 8 patches of 32², on the plush
// dog's photos (73 of 750 x 500: 134 patches visit them in 800 x 0.25 iterations).
namespace {
IterationEstimate dog_estimate() {
  IterationEstimate e;
  e.coarse_share = 0.75;
  e.coarse_spp = e.fine_spp = 32;
  e.coarse_seconds = 0.8, e.coarse_fixed_seconds = 0.0;
  e.fine_seconds = 1.0, e.fine_fixed_seconds = 0.04;  // 8 patches: 0.005 s fixed per patch
  e.fine_views = 8;
  e.fine_patches_auto = true;
  e.fine_view_pixels = 32.0 * 32.0;
  e.train_pixels = 73.0 * 750.0 * 500.0;
  return e;
}
}  // namespace

// On the automatic patches, a rung's full-resolution samples above kPatchSpp buy patches
// (up to kMaxPatchViews) before samples per pixel; every cost of a patch scales with their
// count, so the plan still fits its budget; an explicit batch keeps its spp ladder.
TEST(BudgetPlan, PatchesBeforeSamplesOnTheAutomaticBatch) {
  OptimizerSettings s;
  IterationEstimate e = dog_estimate();
  EXPECT_EQ(data_patch_views(e), 134);    // 27.4 M / (800 x 0.25 x 1024)
  using P = std::pair<int, int>;
  EXPECT_EQ(spread_fine_samples(e, 8), P(8, 0));     // the ladder's foot: the batch as it is
  EXPECT_EQ(spread_fine_samples(e, 16), P(8, 16));   // 128 samples: 16 patches x 8
  EXPECT_EQ(spread_fine_samples(e, 32), P(8, 32));   // 256: 32 x 8
  EXPECT_EQ(spread_fine_samples(e, 64), P(16, 32));  // past kMaxPatchViews: the spp grows
  EXPECT_EQ(spread_fine_samples(e, 128), P(32, 32));
  // A patch's costs scale with the count: 32 patches x 8 spp = 4 x (0.04 + 0.96 / 4).
  EXPECT_NEAR(phase_seconds(e, false, 8, 32), 4.0 * (0.04 + 0.24), 1e-12);
  EXPECT_NEAR(phase_seconds(e, false, 32, 8), 1.0, 1e-12);
  // The pyramid case above at 700 s: the (32, 32) rung, its fine samples as 32 patches x 8,
  // each iteration a little dearer (the patches' fixed cost), 800 of them still fit.
  BudgetPlan p = plan_budget(720.0, e, s);
  EXPECT_EQ(p.coarse_spp, 32);
  EXPECT_EQ(p.spp, 8);
  EXPECT_EQ(p.views, 32);
  EXPECT_GE(p.iterations, kRungIterations);
  EXPECT_LE(p.iterations * p.s_per_iter, 720.0 + 1e-9);
  EXPECT_NEAR(p.s_per_iter, 0.75 * 0.8 + 0.25 * 1.12, 1e-12);
  // Where the dearer patches do not fit a rung's iterations, the rung below is taken: at 600 s
  // the (32, 32) rung gives 681 (the spp ladder's 0.85 s: 705), the (16, 32) one 1034.
  p = plan_budget(600.0, e, s);
  EXPECT_EQ(p.coarse_spp, 16);
  EXPECT_EQ(p.spp, 8);
  EXPECT_EQ(p.views, 32);
  // Where the batch already visits the data's pixels (24 views of 256²: 1.6 M, 8 patches
  // visit 1.6 M in 200 full-resolution iterations), the spp ladder as before.
  e.train_pixels = 24.0 * 256.0 * 256.0;
  EXPECT_EQ(data_patch_views(e), 8);
  EXPECT_EQ(spread_fine_samples(e, 32), P(32, 0));
  e.train_pixels = 100.0 * 400.0 * 400.0;  // 100 views of 400²: 79 patches' worth, capped
  EXPECT_EQ(spread_fine_samples(e, 32), P(8, 32));
  e.train_pixels = 24.0 * 400.0 * 400.0;  // 24 views of 400²: 19 patches
  EXPECT_EQ(spread_fine_samples(e, 32), P(13, 19));
  // An explicit batch (or whole views): the spp ladder as before.
  e.train_pixels = 73.0 * 750.0 * 500.0;
  e.fine_patches_auto = false;
  EXPECT_EQ(spread_fine_samples(e, 32), P(32, 0));
  p = plan_budget(700.0, e, s);
  EXPECT_EQ(p.spp, 32);
  EXPECT_EQ(p.views, 0);
}

// Where the photos hold more pixels than kMaxPatchViews patches visit in the default share,
// a plan that may choose it runs the last half at full resolution (data_fine_share); the
// iteration's cost is then the mean of the two phases at a half each.
TEST(BudgetPlan, LongerFullResolutionShareWhereThePhotosHoldMorePixels) {
  OptimizerSettings s;
  IterationEstimate e = dog_estimate();
  EXPECT_DOUBLE_EQ(data_fine_share(e, 0.25), kLargeDataFineShare);
  EXPECT_DOUBLE_EQ(data_fine_share(e, 0.8), 0.8);  // never below the given share
  // The plan at 720 s: the (32, 32) rung, its fine samples as 32 patches x 8 (1.12 s), the
  // coarse ones 0.8 s, at a half each: 0.96 s, 750 iterations (the quarter's plan: 800).
  BudgetPlan p = plan_budget(720.0, e, s, true);
  EXPECT_DOUBLE_EQ(p.fine_share, 0.5);
  EXPECT_EQ(p.coarse_spp, 32);
  EXPECT_EQ(p.spp, 8);
  EXPECT_EQ(p.views, 32);
  EXPECT_NEAR(p.s_per_iter, 0.5 * 0.8 + 0.5 * 1.12, 1e-12);
  EXPECT_EQ(p.iterations, 750);
  EXPECT_DOUBLE_EQ(plan_budget(720.0, e, s).fine_share, 0.0);  // not asked to choose: the settings'
  // Photos that 32 patches visit (100 views of 256²: 6.6 M, 32 patches' worth) keep the quarter,
  // as do an explicit batch and a run without the pyramid.
  e.train_pixels = 100.0 * 256.0 * 256.0;
  EXPECT_EQ(data_patch_views(e), 32);
  EXPECT_DOUBLE_EQ(plan_budget(720.0, e, s, true).fine_share, 0.0);
  e.train_pixels = 73.0 * 750.0 * 500.0;
  e.fine_patches_auto = false;
  EXPECT_DOUBLE_EQ(data_fine_share(e, 0.25), 0.25);
  e.fine_patches_auto = true;
  e.coarse_share = 0.0;
  EXPECT_DOUBLE_EQ(data_fine_share(e, 1.0), 1.0);
}

TEST(BudgetPlan, PacerLandsOnTheEndTime) {
  const BudgetPacer pacer(100.0);
  // 10 iterations in 5 s, at 10 s since the start: 90 s left at 0.5 s each.
  EXPECT_EQ(pacer.replan(10, 10, 5.0, 10.0, 50), 190);
  EXPECT_EQ(pacer.replan(10, 10, 5.0, 10.0, 189), 189);  // within 1 %: unchanged
  EXPECT_EQ(pacer.replan(10, 10, 5.0, 120.0, 190), 10);  // past the end: stop now
  EXPECT_EQ(pacer.replan(2, 2, 5.0, 10.0, 50), 50);      // too early to tell
}

// The resolution pyramid's two phases: the first coarse_share of a run's iterations cost
// coarse_s each, the rest fine_s; the boundary moves with the total.
TEST(BudgetPlan, TwoPhasePacerCountsEachPhaseAtItsCost) {
  PhaseCosts c;
  c.coarse_share = 0.75;
  c.coarse_s = 1.0;
  c.fine_s = 4.0;
  EXPECT_DOUBLE_EQ(c.seconds_left(0, 100), 75 * 1.0 + 25 * 4.0);
  EXPECT_DOUBLE_EQ(c.seconds_left(80, 100), 20 * 4.0);     // in the fine phase
  EXPECT_DOUBLE_EQ(c.seconds_left(70, 100), 5 * 1.0 + 25 * 4.0);
  EXPECT_DOUBLE_EQ(c.seconds_left(100, 100), 0.0);
  const BudgetPacer pacer(200.0);
  // 175 s of a 100-iteration run; 200 s left at the start: the largest total that fits.
  const int n = pacer.replan(0, 0.0, 10, c);
  EXPECT_LE(c.seconds_left(0, n), 200.0);
  EXPECT_GT(c.seconds_left(0, n + 1), 200.0);
  EXPECT_EQ(n, 115);  // 87 coarse (87 s) + 28 fine (112 s) = 199 s; 116 would be 87 + 29 x 4 = 203 s
  EXPECT_EQ(pacer.replan(20, 250.0, 115, c), 20);  // past the end: stop now
  PhaseCosts unknown;
  unknown.coarse_share = 0.75;
  EXPECT_EQ(pacer.replan(1, 1.0, 50, unknown), 50);  // nothing measured yet
}

// The geometry stage's fine fraction under a budget: the largest share of the run at full
// resolution whose remaining iterations fit in the time, never below the least asked.
TEST(BudgetPlan, FineFractionBuysFullResolutionWithTheTimeLeft) {
  PhaseCosts c;
  c.coarse_share = 0.75;
  c.coarse_s = 1.0;
  c.fine_s = 3.0;
  // 100 iterations, 8 done (coarse): all the rest fine costs 92 x 3 = 276 s.
  EXPECT_DOUBLE_EQ(plan_fine_fraction(276.0, 8, 100, c, 0.25), 0.92);
  EXPECT_DOUBLE_EQ(plan_fine_fraction(1000.0, 8, 100, c, 0.25), 0.92);  // time to spare: still every one left
  // The least (25 fine): 67 coarse + 25 x 3 = 142 s; each moved iteration costs 2 s more.
  EXPECT_DOUBLE_EQ(plan_fine_fraction(142.0, 8, 100, c, 0.25), 0.25);
  EXPECT_DOUBLE_EQ(plan_fine_fraction(150.0, 8, 100, c, 0.25), 0.29);  // 8 s: 4 moved
  EXPECT_DOUBLE_EQ(plan_fine_fraction(151.9, 8, 100, c, 0.25), 0.29);  // not 5
  EXPECT_DOUBLE_EQ(plan_fine_fraction(100.0, 8, 100, c, 0.25), 0.25);  // short of the least: the pacer cuts the count
  // The plan fits, and one more iteration at full resolution would not.
  auto seconds = [&](int boundary) { return (boundary - 8) * c.coarse_s + (100 - boundary) * c.fine_s; };
  for (double t : {150.0, 200.0, 250.0}) {
    const int boundary = 100 - int(std::lround(100.0 * plan_fine_fraction(t, 8, 100, c, 0.25)));
    EXPECT_LE(seconds(boundary), t) << t;
    EXPECT_GT(seconds(boundary - 1), t) << t;
  }
  PhaseCosts unknown;
  EXPECT_DOUBLE_EQ(plan_fine_fraction(500.0, 8, 100, unknown, 0.25), 0.25);  // nothing measured
}

TEST(PatchBatch, PatchesOnlyWhereAViewIsMuchLargerThanTheBatch) {
  PatchBatch b = default_patch_batch(64, 64, 24);  // 4096 pixels: whole views
  EXPECT_EQ(b.side, 0);
  EXPECT_EQ(b.views, 1);
  b = default_patch_batch(128, 128, 24);  // twice the batch's 8192 pixels: still whole views (measured)
  EXPECT_EQ(b.side, 0);
  b = default_patch_batch(182, 182, 24);  // past twice
  EXPECT_EQ(b.side, kDefaultPatchSide);
  b = default_patch_batch(256, 256, 24);
  EXPECT_EQ(b.side, kDefaultPatchSide);
  EXPECT_EQ(b.views, kDefaultPatchViews);
  b = default_patch_batch(256, 256, 3);  // never more patches than views
  EXPECT_EQ(b.views, 3);
  int views = 0, crop = -1;
  resolve_patch_batch(256, 256, 24, &views, &crop);
  EXPECT_EQ(views, kDefaultPatchViews);
  EXPECT_EQ(crop, kDefaultPatchSide);
  views = 2, crop = -1;  // given views, automatic side
  resolve_patch_batch(256, 256, 24, &views, &crop);
  EXPECT_EQ(views, 2);
  EXPECT_EQ(crop, kDefaultPatchSide);
  views = 0, crop = 0;  // whole views asked for: one per iteration
  resolve_patch_batch(256, 256, 24, &views, &crop);
  EXPECT_EQ(views, 1);
  EXPECT_EQ(crop, 0);
}
