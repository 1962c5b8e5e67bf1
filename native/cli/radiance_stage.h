// `ptir optimize --gaussians IN.ply --out OUT` without --dataset: the inversion
// on targets rendered from the splats' own captured radiance (docs/relightable.md).
// This stage plans the views (an orbit around the splats, scene/orbit_views.h, or
// the poses of a 3DGS cameras.json), writes OUT/views.json, renders every view's
// radiance once into OUT/radiance/ (render/radiance_targets.h: cached, resumable)
// and hands the optimiser that folder as its dataset.
//
// The plan and its targets change together or not at all: a plan that differs
// from the one in OUT/radiance/ (its key) is rendered into OUT/.plan-staging/
// (views.json and radiance/; a run stopped there continues it) and replaces
// OUT/views.json and OUT/radiance/ only once every target is there
// (io/atomic_folder.h), so a full disk or an error midway leaves the result's
// own plan beside it. Targets that no pixel of reaches the inversion's mask
// (alpha 0.99 nowhere: splats too transparent) fail the command naming the PLY:
// the run would learn nothing and write the untrained materials.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "ptir/optim/optimizer_setup.h"
#include "ptir/scene/orbit_views.h"

namespace ptir::cli {

struct RadianceStage {
  std::string gaussians, out;
  std::string cameras;    // --cameras: a 3DGS cameras.json (or its output folder); "" = orbit
  OrbitOptions orbit;     // --orbit-* flags
  int target_spp = 4;     // --target-spp (filter-jittered; docs/relightable.md)
  int max_side = 0;       // --orbit-size with --cameras: the long side of the targets (0: 800)
  bool quiet = false;
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

void add_radiance_flags(CLI::App* cmd, RadianceStage* r);

// Its defaults (docs/relightable.md: a 100K-splat object in minutes on 2 cores):
// random 128-pixel crops of the virtual views, 16 spp, 400 iterations, a neutral
// light, where the flags are not given. Applied first, as the flags' own defaults
// are: what a resumed budget recorded (its planned spp) goes over them.
void apply_radiance_defaults(OptimizeOptions& opt, const CLI::App& cmd);

// The files the stage reads besides the PLY (--cameras: the file, or a folder's
// cameras.json), for the output guard: a plan's own OUT/views.json given back as
// --cameras would be replaced by the plan.
std::vector<std::string> radiance_input_files(const RadianceStage& r);

// Renders (or reuses) the targets. Returns 0 with *dataset = OUT/radiance (with
// --estimate: the estimate's folder) and
// *sh_degree = the PLY's SH degree, or 130 when Ctrl-C stopped it (the views
// rendered so far stay cached for the next run).
int run_radiance_stage(const RadianceStage& r, std::string* dataset, int* sh_degree, double* remaining_s = nullptr);

}  // namespace ptir::cli
