#include "ptir/optim/budget_plan.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>

#include "ptir/core/error.h"

namespace ptir {

double parse_duration(const std::string& text, const std::string& what) {
  const char* s = text.c_str();
  char* end = nullptr;
  // A decimal number (digits, a point, an exponent) and a unit: strtod alone would
  // also take leading blanks, hex, "inf" and "nan".
  const bool decimal = !text.empty() && (std::isdigit(static_cast<unsigned char>(text[0])) || text[0] == '.') &&
                       text.find_first_of("xXpP") == std::string::npos;
  const double v = decimal ? std::strtod(s, &end) : 0.0;
  const std::string unit(end == nullptr ? "" : end);
  double scale = 0.0;
  if (unit.empty() || unit == "s") scale = 1.0;
  else if (unit == "m" || unit == "min") scale = 60.0;
  else if (unit == "h") scale = 3600.0;
  if (!decimal || end == s || scale == 0.0 || !std::isfinite(v) || !(v > 0.0))
    throw Error(what + " must be a positive duration such as 90s, 10m or 1.5h, got '" + text + "'");
  const double seconds = v * scale;
  if (!(seconds >= kMinBudgetSeconds && seconds <= kMaxBudgetSeconds))
    throw Error(what + " must be between 1 s and 30 days (720h), got '" + text + "'" +
                (seconds < kMinBudgetSeconds ? " (under a second: no iteration would run)" : ""));
  return seconds;
}

int iterations_within(double seconds, double per_iteration) {
  if (!(seconds > 0.0) || !(per_iteration > 0.0) || !std::isfinite(seconds)) return 0;
  const double n = std::floor(seconds / per_iteration);  // may be inf for a tiny per_iteration
  return n >= double(kMaxBudgetIterations) ? kMaxBudgetIterations : int(n);
}

namespace {
// Fixed costs plus a per-sample part proportional to the spp, from `seconds` at `at_spp`.
double at_spp(double seconds, double fixed, int at_spp, int spp) {
  return at_spp > 0 ? fixed + (seconds - fixed) * double(spp) / double(at_spp) : seconds;
}
}  // namespace

double phase_seconds(const IterationEstimate& e, bool coarse, int spp, int views) {
  if (coarse) return at_spp(e.coarse_seconds, e.coarse_fixed_seconds, e.coarse_spp, spp);
  const double per_view = views > 0 && e.fine_views > 0 ? double(views) / double(e.fine_views) : 1.0;
  return per_view * at_spp(e.fine_seconds, e.fine_fixed_seconds, e.fine_spp, spp);
}

int data_patch_views(const IterationEstimate& e) {
  const double fine_iterations = double(kReferenceIterations) * (1.0 - std::clamp(e.coarse_share, 0.0, 1.0));
  const double per_patch = fine_iterations * e.fine_view_pixels;
  if (!(per_patch > 0.0) || !(e.train_pixels > 0.0)) return e.fine_views;
  return int(std::min(1e6, std::ceil(e.train_pixels / per_patch)));
}

std::pair<int, int> spread_fine_samples(const IterationEstimate& e, int fine_spp) {
  if (!e.fine_patches_auto || e.fine_views <= 0 || fine_spp <= kPatchSpp) return {fine_spp, 0};
  // The rung's samples per iteration (fine_spp x the batch's patches), as patches of
  // kPatchSpp up to kMaxPatchViews and no more than the data's pixels ask for, the rest
  // as samples per pixel.
  const int most = std::max(e.fine_views, std::min(kMaxPatchViews, data_patch_views(e)));
  if (most == e.fine_views) return {fine_spp, 0};
  const long samples = long(fine_spp) * e.fine_views;
  const int views = int(std::clamp<long>(samples / kPatchSpp, e.fine_views, most));
  return {int(std::max<long>(kPatchSpp, samples / views)), views};
}

double iteration_seconds(const IterationEstimate& e, const OptimizerSettings& s, int spp, int coarse_spp, int views) {
  if (e.fine_spp <= 0) return at_spp(e.seconds, e.fixed_seconds, s.integrator.spp, spp);  // one phase, at the settings' spp
  const double fine = phase_seconds(e, false, spp, views);
  if (!(e.coarse_share > 0.0)) return fine;
  return e.coarse_share * phase_seconds(e, true, coarse_spp > 0 ? coarse_spp : spp) + (1.0 - e.coarse_share) * fine;
}

double data_fine_share(const IterationEstimate& e, double share) {
  if (!e.fine_patches_auto || !(e.coarse_share > 0.0) || data_patch_views(e) <= kMaxPatchViews) return share;
  return std::max(share, kLargeDataFineShare);
}

BudgetPlan plan_budget(double seconds, const IterationEstimate& estimate, const OptimizerSettings& s,
                       bool choose_fine_share) {
  BudgetPlan p;
  IterationEstimate e = estimate;
  if (choose_fine_share) {  // the photos' pixels may ask for a longer full-resolution phase
    const double share = data_fine_share(estimate, 1.0 - estimate.coarse_share);
    if (share > 1.0 - estimate.coarse_share) {
      e.coarse_share = 1.0 - share;
      p.fine_share = share;
    }
  }
  auto iterations_at = [&](int spp, int coarse, int views) {
    return iterations_within(seconds, std::max(1e-9, iteration_seconds(e, s, spp, coarse, views)));
  };
  // The most samples that still give (nearly) kReferenceIterations, on the ladder of
  // kSppRungs (one phase, without the pyramid: the rungs' fine spp); below its first
  // rung, fewer iterations at its 8 spp. On the automatic patches, a rung's full-resolution
  // samples go to more patches first (spread_fine_samples).
  const bool pyramid = e.coarse_share > 0.0;
  for (const SppRung& r : kSppRungs) {
    const auto [spp, views] = spread_fine_samples(e, r.fine);
    if (p.spp == 0 || iterations_at(spp, pyramid ? r.coarse : 0, views) >= kRungIterations) {
      p.spp = spp;
      p.views = views;
      p.coarse_spp = pyramid ? r.coarse : 0;
    }
  }
  p.iterations = std::max(1, iterations_at(p.spp, p.coarse_spp, p.views));
  p.s_per_iter = iteration_seconds(e, s, p.spp, p.coarse_spp, p.views);
  return p;
}

int BudgetPacer::replan(int done, int done_here, double elapsed_s, double now_s, int total) const {
  if (done_here < 3 || elapsed_s <= 0.0) return total;  // the first iterations warm caches up
  const double rate = elapsed_s / double(done_here);
  const double left = end_s_ - now_s;
  const int want = done + std::min(iterations_within(left, rate), kMaxBudgetIterations - std::max(0, done));
  if (std::abs(want - total) <= std::max(1, total / 100) && want >= done) return total;
  return std::max(done, want);
}

double PhaseCosts::seconds_left(int done, int total) const {
  if (total <= done) return 0.0;
  // Coarse iterations are those with it < coarse_share x total (Optimizer::pyramid_level_factor).
  const int boundary = std::clamp(int(std::ceil(coarse_share * double(total))), 0, total);
  const int coarse = std::max(0, boundary - done), fine = total - std::max(boundary, done);
  return double(coarse) * coarse_s + double(fine) * fine_s;
}

double plan_fine_fraction(double seconds_left, int done, int total, const PhaseCosts& costs, double least) {
  least = std::clamp(least, 0.0, 1.0);
  if (total <= 0 || !(costs.coarse_s > 0.0) || !(costs.fine_s > costs.coarse_s)) return least;
  // The coarse iterations are [0, boundary): each one moved to full resolution costs
  // fine_s - coarse_s more, so the earliest boundary >= done whose time fits gives the answer.
  const int latest = std::clamp(int(std::ceil((1.0 - least) * double(total))), 0, total);
  const double all_coarse = double(std::max(0, latest - done)) * costs.coarse_s +
                            double(total - std::max(latest, done)) * costs.fine_s;
  const double spare = seconds_left - all_coarse;
  if (!(spare > 0.0)) return least;
  const int movable = std::max(0, latest - done);
  const int moved = std::min(movable, int(std::floor(spare / (costs.fine_s - costs.coarse_s))));
  return std::max(least, double(total - (latest - moved)) / double(total));
}

int BudgetPacer::replan(int done, double now_s, int total, const PhaseCosts& costs) const {
  if (!(costs.coarse_s > 0.0 && costs.fine_s > 0.0)) return total;  // nothing measured yet
  const double left = end_s_ - now_s;
  const double cheapest = std::max(1e-9, std::min(costs.coarse_s, costs.fine_s));
  if (!(left > 0.0)) return done;
  // Binary search on the total: the seconds left grow with it (each added iteration costs
  // at least a coarse one, whatever the boundary's move).
  int lo = done, hi = done + int(std::min(1e7, left / cheapest)) + 1;
  while (lo < hi) {
    const int mid = lo + (hi - lo + 1) / 2;
    if (costs.seconds_left(done, mid) <= left) lo = mid;
    else hi = mid - 1;
  }
  if (std::abs(lo - total) <= std::max(1, total / 100) && total >= done) return total;
  return lo;
}

void PhaseClock::add(int level, double wall_s) {
  const int p = level > 1 ? 0 : 1;
  if (++seen_[p] <= 2) return;
  seconds_[p] += wall_s;
  ++count_[p];
}

PhaseCosts PhaseClock::costs(double coarse_share, double fine_over_coarse) const {
  PhaseCosts c;
  c.coarse_share = coarse_share;
  const double ratio = fine_over_coarse > 0.0 ? fine_over_coarse : 1.0;
  const bool coarse = count_[0] >= 3, fine = count_[1] >= 3;
  c.coarse_s = coarse ? seconds_[0] / count_[0] : fine ? seconds_[1] / count_[1] / ratio : 0.0;
  c.fine_s = fine ? seconds_[1] / count_[1] : coarse ? c.coarse_s * ratio : 0.0;
  return c;
}

}  // namespace ptir
