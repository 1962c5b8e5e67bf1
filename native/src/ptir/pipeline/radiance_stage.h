// `ptir optimize --gaussians IN.ply --out OUT` without --dataset: the inversion
// on targets rendered from the splats' own captured radiance (docs/relightable.md).
// This stage plans the views (an orbit around the splats, scene/orbit_views.h, or
// the poses of a 3DGS cameras.json), writes OUT/views.json, renders every view's
// radiance once into OUT/radiance/ (render/radiance_targets.h: cached, resumable)
// and hands the optimiser that folder as its dataset.
//
// The plan, its targets and the results change together or not at all: a plan
// that differs from the one in OUT/radiance/ (its key) is rendered into
// OUT/.plan-staging/ (views.json and radiance/), the run trains on it there, and
// it replaces OUT/views.json and OUT/radiance/ (io/atomic_folder.h) once the
// run has written its results (PendingPlan). A full disk or an error anywhere
// before leaves the previous plan beside the previous results (the optimiser's
// own outputs roll back: io/output_rollback.h); a run stopped or killed leaves
// the staged plan for the next run to continue. Targets that no pixel of reaches the inversion's mask
// (alpha 0.99 nowhere: splats too transparent) fail the command naming the PLY:
// the run would learn nothing and write the untrained materials.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "ptir/optim/optimizer_setup.h"
#include "ptir/pipeline/given_options.h"
#include "ptir/pipeline/progress_printer.h"
#include "ptir/scene/orbit_views.h"

namespace ptir::pipeline {

struct RadianceStage {
  std::string gaussians, out;
  std::string cameras;    // --cameras: a 3DGS cameras.json (or its output folder); "" = orbit
  std::string up;         // --up: the splats' up axis (scene/splat_up_axis.h); "" = decided from the data
  OrbitOptions orbit;     // --orbit-* flags
  int target_spp = 4;     // --target-spp (filter-jittered; docs/relightable.md)
  int max_side = 0;       // --orbit-size with --cameras: the long side of the targets (0: 800)
  bool quiet = false;
  ProgressPrinter progress;  // the targets rendered (text or JSON; silent when quiet)
  // --estimate: only the first view is rendered (the probe's), into estimate_dir
  // (a scratch folder of the caller's, outside OUT: the estimate writes nothing
  // there); the time the others will take (that view's, each) goes to *remaining_s.
  bool estimate = false;
  std::string estimate_dir;
};

// --estimate's scratch folder for the probe's target: made in the system's temp
// folder (named by `pid`: the same on every MPI rank of one machine), removed with
// its contents when the object goes.
class ScratchFolder {
 public:
  explicit ScratchFolder(long pid);
  ~ScratchFolder();
  ScratchFolder(const ScratchFolder&) = delete;
  ScratchFolder& operator=(const ScratchFolder&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// Its defaults (docs/relightable.md: a 100K-splat object in minutes on 2 cores):
// random 128-pixel crops of the virtual views, 16 spp, 400 iterations, a neutral
// light, where the flags are not given. Applied first, as the flags' own defaults
// are: what a resumed budget recorded (its planned spp) goes over them.
void apply_radiance_defaults(OptimizeOptions& opt, const GivenOptions& given);

// The files the stage reads besides the PLY (--cameras: the file, or a folder's
// cameras.json), for the output guard: a plan's own OUT/views.json given back as
// --cameras would be replaced by the plan.
std::vector<std::string> radiance_input_files(const RadianceStage& r);

// Where a new plan is staged, inside OUT.
constexpr const char* kPlanStaging = ".plan-staging";

// A new plan staged in OUT/.plan-staging/: commit() puts it in place of
// OUT/radiance/ and OUT/views.json (after the run's results are written, also
// when Ctrl-C stopped it with its outputs); without a commit (a failure) the
// staging folder goes with the object, unless keep() (a stopped stage).
class PendingPlan {
 public:
  explicit PendingPlan(const std::string& out);
  ~PendingPlan();
  PendingPlan(const PendingPlan&) = delete;
  PendingPlan& operator=(const PendingPlan&) = delete;
  void commit();
  void keep() { keep_ = true; }

 private:
  std::string out_;
  bool keep_ = false;
};

// Renders (or reuses) the targets. Returns 0 with *dataset = the targets' folder,
// *sh_degree = the PLY's SH degree and *pending = the new plan to commit with the
// results (*dataset is then OUT/.plan-staging/radiance), or null where OUT/radiance
// holds this plan (or --estimate: *dataset is its folder); or 130 when Ctrl-C
// stopped it (the views rendered so far stay cached for the next run). Throws
// Error naming the PLY when the targets cannot train (radiance_stage.h, above).
int run_radiance_stage(const RadianceStage& r, std::string* dataset, int* sh_degree, double* remaining_s,
                       std::shared_ptr<PendingPlan>* pending);

}  // namespace ptir::pipeline
