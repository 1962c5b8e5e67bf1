// The radiance-target stage of `ptir optimize` without --dataset (radiance_stage.h).
#include "ptir/pipeline/radiance_stage.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>

#include "ptir/accel/scene_accel.h"
#include "ptir/core/error.h"
#include "ptir/core/fnv1a.h"
#include "ptir/io/atomic_file.h"
#include "ptir/io/atomic_folder.h"
#include "ptir/optim/optimizer.h"
#include "ptir/render/radiance_targets.h"
#include "ptir/scene/dataset.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/splat_up_axis.h"
#include "ptir/pipeline/run_control.h"

namespace ptir::pipeline {

namespace fs = std::filesystem;

void apply_radiance_defaults(OptimizeOptions& opt, const GivenOptions& given) {
  if (given.count("--iters") == 0) opt.iters = 400;
  if (given.count("--spp") == 0) opt.spp = 16;
  if (given.count("--crop") == 0) opt.crop = 128;
  if (given.count("--neutral-light") == 0) opt.neutral_light = true;
}

std::vector<std::string> radiance_input_files(const RadianceStage& r) {
  std::error_code ec;
  if (r.cameras.empty()) return {};
  return {fs::is_directory(r.cameras, ec) ? (fs::path(r.cameras) / "cameras.json").string() : r.cameras};
}

namespace {

// The PLY's identity for the cache key: path, size and modification time.
std::string file_identity(const std::string& path) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  const auto time = fs::last_write_time(path, ec).time_since_epoch().count();
  return fs::absolute(path, ec).string() + " " + std::to_string(size) + " " + std::to_string(time);
}

// --cameras: every pose of the cameras.json, at one size whose long side is max_side.
std::vector<Camera> capture_cameras(const std::string& given, int max_side) {
  const fs::path p = fs::is_directory(given) ? fs::path(given) / "cameras.json" : fs::path(given);
  std::vector<Camera> cams = load_3dgs_cameras(p.string());
  const int side = max_side > 0 ? max_side : 800;
  const float s = std::min(1.0f, float(side) / float(std::max(cams[0].width, cams[0].height)));
  const int w = std::max(16, int(std::lround(cams[0].width * s))), h = std::max(16, int(std::lround(cams[0].height * s)));
  for (Camera& c : cams) c = c.resized(w, h);
  return cams;
}

}  // namespace

ScratchFolder::ScratchFolder(long pid) {
  std::error_code ec;
  fs::path base = fs::temp_directory_path(ec);
  if (ec) base = "/tmp";
  path_ = (base / ("ptir-estimate-" + std::to_string(pid))).string();
  fs::remove_all(path_, ec);  // one a killed estimate of this pid left
  fs::create_directories(path_, ec);
  if (ec) throw Error(path_, "cannot create the estimate's scratch folder: " + ec.message());
}

ScratchFolder::~ScratchFolder() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

namespace {

// The views' plan: the cameras and their JSON text (OUT/views.json).
std::vector<Camera> plan_views(const RadianceStage& r, const GaussianField& field, std::string* plan_text) {
  if (!r.cameras.empty()) {
    std::vector<Camera> cameras = capture_cameras(r.cameras, r.orbit.size);
    const nlohmann::json plan = {{"cameras_from", r.cameras}, {"views", cameras.size()}, {"width", cameras[0].width},
                                 {"height", cameras[0].height}};
    *plan_text = with_up_axis(plan.dump(), decide_up_axis(field, r.up, cameras));
    if (!r.quiet)
      std::fprintf(stderr, "optimize: no --dataset: %zu views from %s at %dx%d, radiance from the splats\n", cameras.size(),
                   r.cameras.c_str(), cameras[0].width, cameras[0].height);
    return cameras;
  }
  const UpAxis up = decide_up_axis(field, r.up, {});
  OrbitOptions orbit = r.orbit;
  orbit.up = up.up;
  const OrbitPlan plan = plan_orbit(field, orbit);
  *plan_text = with_up_axis(orbit_plan_json(plan, r.gaussians), up);
  if (!r.quiet) {
    std::fprintf(stderr,
                 "optimize: no --dataset: %d orbit views %dx%d around the splats (radius %.3g about (%.3g, %.3g, %.3g), "
                 "distance %.3g, elevation %.0f..%.0f deg about up (%.2f, %.2f, %.2f) from %s), radiance from the "
                 "splats (SH degree %d)\n",
                 plan.views, plan.size, plan.size, plan.bounds.radius, plan.bounds.centre.x, plan.bounds.centre.y,
                 plan.bounds.centre.z, plan.distance, plan.elevation_min, plan.elevation_max, up.up.x, up.up.y, up.up.z,
                 up.source.c_str(), field.sh_degree);
    if (plan.distance <= plan.bounds.radius)
      std::fprintf(stderr, "warning: --orbit-distance %.3g puts the cameras inside the splats' bounds: the targets "
                           "see the object from inside\n", r.orbit.distance_scale);
  }
  return plan.cameras;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  if (in) ss << in.rdbuf();
  return ss.str();
}

// Targets no pixel of which the inversion's mask takes (optimizer.h: alpha >= 0.99):
// every iteration would have an empty loss, zero gradients, and write the priors.
void check_targets_cover(const RadianceStage& r, const RadianceTargetReport& rep, size_t views) {
  const float threshold = OptimizerSettings{}.mask_threshold;
  if (rep.max_alpha >= threshold) return;
  char a[32], t[32];
  std::snprintf(a, sizeof a, "%.3g", double(rep.max_alpha));
  std::snprintf(t, sizeof t, "%.2g", double(threshold));
  throw Error(r.gaussians, "the splats never cover a pixel fully: the most opaque pixel of their " + std::to_string(views) +
                               " radiance targets has alpha " + a + ", and the inversion learns only from pixels of alpha >= " +
                               t + " (object, not silhouette), so nothing would be learnt. The splats are too transparent "
                               "(low opacities, or too small and sparse for the views): a trained 3DGS PLY covers its object");
}

}  // namespace

PendingPlan::PendingPlan(const std::string& out) : out_(out) {}

PendingPlan::~PendingPlan() {
  std::error_code ec;
  if (!keep_) fs::remove_all(fs::path(out_) / kPlanStaging, ec);
}

void PendingPlan::commit() {
  const fs::path out(out_), staging = out / kPlanStaging;
  io::replace_folder((staging / "radiance").string(), (out / "radiance").string());
  std::error_code ec;
  fs::rename(staging / "views.json", out / "views.json", ec);
  if (ec) throw Error((out / "views.json").string(), "cannot move the new plan in place: " + ec.message());
  keep_ = false;  // the rest of the staging folder (the old targets) goes
}

int run_radiance_stage(const RadianceStage& r, std::string* dataset, int* sh_degree, double* remaining_s,
                       std::shared_ptr<PendingPlan>* pending) {
  if (r.target_spp < 1) throw Error("--target-spp must be at least 1");
  const auto t0 = std::chrono::steady_clock::now();
  GaussianField field = load_gaussians(r.gaussians);
  *sh_degree = field.sh_degree;
  std::string plan_text;
  std::vector<Camera> cameras = plan_views(r, field, &plan_text);

  RadianceTargetSettings s;
  s.spp = r.target_spp;
  s.key = "ptir radiance targets v1\n" + file_identity(r.gaussians) + "\nspp " + std::to_string(r.target_spp) + "\n" +
          std::to_string(fnv1a(plan_text)) + "\n";
  s.cancel = &g_interrupted;
  const ProgressPrinter progress = r.progress.quiet(r.quiet);
  s.progress = [&](int done, int total, bool rendered) {
    if (rendered)
      progress.radiance_target(done, total,
                               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    return !g_interrupted.load();
  };
  // Where the targets go: the probe's view alone in the estimate's scratch folder; the
  // plan OUT/radiance holds (its key) in place; a new plan staged (radiance_stage.h).
  const fs::path out(r.out), live = out / "radiance", staging = out / kPlanStaging;
  fs::path dir = live;
  const size_t all_views = cameras.size();
  std::shared_ptr<PendingPlan> staged;
  if (r.estimate) {
    cameras.resize(1);
    dir = r.estimate_dir;
  } else {
    std::error_code ec;
    fs::create_directories(out, ec);
    if (ec) throw Error(r.out, "cannot create the output folder: " + ec.message());
    if (read_text(live / "key.txt") != s.key) {
      dir = staging / "radiance";
      staged = std::make_shared<PendingPlan>(r.out);
      fs::create_directories(staging, ec);
      if (ec) throw Error(staging.string(), "cannot create the folder: " + ec.message());
      io::write_text_atomic((staging / "views.json").string(), plan_text);
    } else {
      fs::remove_all(staging, ec);  // a plan staged and abandoned for this one
      if (read_text(out / "views.json") != plan_text) io::write_text_atomic((out / "views.json").string(), plan_text);
    }
  }
  const auto t_render = std::chrono::steady_clock::now();
  RadianceTargetReport rep;
  {
    SceneAccel accel(field, {});
    const SignalHandler previous = install_sigint();
    rep = with_sigint_restored(previous, [&] { return render_radiance_targets(accel, cameras, dir.string(), s); });
  }
  if (rep.cancelled) {
    if (staged) staged->keep();  // its targets are the next run's
    std::fprintf(stderr, "ptir: interrupted while rendering the radiance targets; %d views are cached in %s (run the same "
                 "command again to continue)\n", rep.rendered + rep.reused, dir.string().c_str());
    return 130;
  }
  if (remaining_s)
    *remaining_s = r.estimate ? std::chrono::duration<double>(std::chrono::steady_clock::now() - t_render).count() *
                                    double(all_views - 1)
                              : 0.0;
  if (!r.estimate) check_targets_cover(r, rep, cameras.size());  // (a staged plan goes with the error)
  *pending = staged;  // committed with the run's results
  if (!r.quiet)
    std::fprintf(stderr, "radiance: %d views rendered, %d reused from %s (%s)\n", rep.rendered, rep.reused,
                 dir.string().c_str(),
                 duration_text(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()).c_str());
  *dataset = dir.string();
  return 0;
}

}  // namespace ptir::pipeline
