#include "ptir/pipeline/optimize_budget.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/optim/budget_plan.h"
#include "ptir/optim/iteration_estimate.h"
#include "ptir/optim/optimizer.h"
#include "ptir/scene/dataset.h"

namespace ptir::pipeline {

namespace {
std::string budget_text(double seconds) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g s", seconds);
  return b;
}
std::string budget_path(const std::string& out_dir) { return (std::filesystem::path(out_dir) / "budget.json").string(); }

// Photos as a camera took them: the capture stage's calibration applies to them (its masks are
// its object's coverage), or, before that stage (--estimate), a capture's layout (COLMAP, 3DGS,
// nerfstudio) without masks of its own, the room around the object in every photo. A rendered
// set on a transparent film keeps the settings' full-resolution share (budget_plan.h:
// kLargeDataFineShare, measured both ways).
bool unmasked_photos(const Dataset& d) {
  if (!d.calibration_record.empty()) return true;
  if (d.layout == "nerf") return false;
  for (const DatasetView& v : d.views)
    if (!v.files.mask.empty()) return false;
  return true;
}
}  // namespace

BudgetState read_budget_state(const std::string& out_dir) {
  BudgetState b;
  const std::string path = budget_path(out_dir);
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return b;
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  try {
    const nlohmann::json j = nlohmann::json::parse(text.str());
    b.budget_s = j.at("budget_s").get<double>();
    b.spent_s = j.at("spent_s").get<double>();
    b.spp = j.at("spp").get<int>();
    b.coarse_spp = j.value("coarse_spp", 0);
    b.views = j.value("views", 0);  // (absent in a budget planned before the patch count was)
    b.fine_share = j.value("fine_share", 0.0);  // (absent: the settings' share)
  } catch (const std::exception& e) {
    throw Error(path, std::string("not a budget record (budget_s, spent_s, spp): ") + e.what());
  }
  if (!(b.budget_s >= kMinBudgetSeconds && b.budget_s <= kMaxBudgetSeconds) || !(b.spent_s >= 0.0 && b.spent_s <= 1e9) ||
      b.spp < 0 || b.coarse_spp < 0 || b.views < 0 || b.views > 4096 || !(b.fine_share >= 0.0 && b.fine_share <= 1.0))
    throw Error(path, "budget_s, spent_s, spp, coarse_spp, views or fine_share out of range");
  return b;
}

void write_budget_state(const std::string& out_dir, const BudgetState& b) {
  nlohmann::ordered_json j;
  j["budget_s"] = b.budget_s;
  j["spent_s"] = b.spent_s;
  j["spp"] = b.spp;
  j["coarse_spp"] = b.coarse_spp;
  if (b.views > 0) j["views"] = b.views;
  if (b.fine_share > 0.0) j["fine_share"] = b.fine_share;
  io::write_text_atomic(budget_path(out_dir), j.dump() + "\n");
}

BudgetState plan_optimizer_budget(Optimizer& opt, BudgetState b, std::chrono::steady_clock::time_point t_start,
                                  bool quiet) {
  const double since_start = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  const double left = b.budget_s - b.spent_s - since_start - kOutputReserve;
  if (b.spp > 0) {  // a resumed budget keeps its spp
    opt.set_spp(b.spp);
    opt.set_coarse_spp(b.coarse_spp);
  }
  const IterationEstimate est = estimate_iteration(opt);
  int iterations = 0;
  if (b.spp > 0) {
    iterations = iterations_within(left, std::max(1e-9, est.seconds));
  } else {
    const BudgetPlan p =
        plan_budget(std::max(0.0, left), est, opt.settings(), b.choose_fine_share && unmasked_photos(opt.dataset()));
    iterations = left > 0.0 ? p.iterations : 0;
    if (p.fine_share > 0.0) {
      opt.set_fine_fraction(float(p.fine_share));
      b.fine_share = p.fine_share;
    }
    opt.set_spp(p.spp);
    opt.set_coarse_spp(p.coarse_spp);
    if (p.views > 0) opt.set_views_per_iteration(p.views);
  }
  if (iterations == 0 && opt.iteration() == 0)  // an untrained result is no result
    throw Error("--budget " + budget_text(b.budget_s) + ": no iteration fits in it (" + budget_text(since_start) +
                " went on loading and preparing, " + budget_text(b.spent_s) + " earlier, " + budget_text(kOutputReserve) +
                " are kept for the outputs): give a larger budget (--estimate prints what a run needs)");
  opt.set_iterations(opt.iteration() + iterations);
  b.spp = opt.settings().integrator.spp;
  b.coarse_spp = opt.settings().coarse_spp;
  b.views = opt.auto_views() || b.views > 0 ? opt.settings().views_per_iteration : 0;
  // The phases' estimates at the planned spp; their ratio is what the pacer uses.
  b.est_coarse_s = est.fine_spp > 0 ? phase_seconds(est, true, opt.spp_at(2)) : est.coarse_seconds;
  b.est_fine_s = est.fine_spp > 0 ? phase_seconds(est, false, b.spp, b.views) : est.fine_seconds;
  if (!quiet) {
    const bool pyramid = opt.pyramid_coarse_share() > 0.0;
    const std::string coarse = " (" + std::to_string(opt.spp_at(2)) + " while coarse, the last " +
                               std::to_string(int(std::lround(100.0 * opt.settings().fine_fraction))) +
                               " % at full resolution)";
    std::fprintf(stderr, "optimize: budget %.0f s (%.0f s left): %d iterations at %d spp%s, %d patch(es) of %s per iteration\n",
                 b.budget_s, std::max(0.0, left), iterations, b.spp, pyramid ? coarse.c_str() : "",
                 opt.settings().views_per_iteration,
                 opt.settings().crop_size > 0 ? (std::to_string(opt.settings().crop_size) + "^2").c_str() : "whole views");
  }
  return b;
}

int print_estimate(const Optimizer& opt, std::chrono::steady_clock::time_point t_start, double budget_s,
                   double extra_setup_s, bool choose_fine_share) {
  IterationEstimate est = estimate_iteration(opt);
  const double setup = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count() + extra_setup_s;
  int iters = opt.settings().iterations - opt.iteration(), spp = opt.settings().integrator.spp,
      coarse_spp = opt.pyramid_coarse_share() > 0.0 ? opt.spp_at(2) : 0;
  int views = opt.settings().views_per_iteration;
  double fine_share = opt.pyramid_coarse_share() > 0.0 ? double(opt.settings().fine_fraction) : 1.0;
  if (budget_s > 0.0) {
    const BudgetPlan p =
        plan_budget(std::max(0.0, budget_s - setup - kOutputReserve), est, opt.settings(),
                    choose_fine_share && unmasked_photos(opt.dataset()));
    if (p.fine_share > 0.0) fine_share = p.fine_share;
    iters = p.iterations;
    spp = p.spp;
    coarse_spp = p.coarse_spp;
    if (p.views > 0) views = p.views;
    est.seconds = p.s_per_iter;
  }
  std::printf("{\"estimate\": {\"setup_s\": %.4f, \"s_per_iter\": %.6f, \"iterations\": %d, \"total_s\": %.3f, "
              "\"gaussians\": %zu, \"views\": %zu, \"width\": %d, \"height\": %d, \"probe_pixels\": %d, "
              "\"probe_spp\": %d, \"spp\": %d, \"coarse_spp\": %d, \"views_per_iter\": %d, \"crop\": %d, \"fine_share\": %.4g, "
              "\"budget_s\": %.1f}}\n",
              setup, est.seconds, iters, setup + iters * est.seconds, opt.scene().gaussians->size(),
              opt.dataset().size(), opt.dataset().width, opt.dataset().height, est.probe_pixels, est.probe_spp, spp, coarse_spp,
              views, opt.settings().crop_size, fine_share, budget_s);
  std::fflush(stdout);
  return 0;
}


}  // namespace ptir::pipeline
