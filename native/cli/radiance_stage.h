// `ptir optimize --gaussians IN.ply --out OUT` without --dataset: the inversion
// on targets rendered from the splats' own captured radiance (docs/relightable.md).
// This stage plans the views (an orbit around the splats, scene/orbit_views.h, or
// the poses of a 3DGS cameras.json), writes OUT/views.json, renders every view's
// radiance once into OUT/radiance/ (render/radiance_targets.h: cached, resumable)
// and hands the optimiser that folder as its dataset.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "ptir/scene/orbit_views.h"

namespace ptir::cli {

struct RadianceStage {
  std::string gaussians, out;
  std::string cameras;    // --cameras: a 3DGS cameras.json (or its output folder); "" = orbit
  std::string up;         // --up: the splats' up axis (scene/splat_up_axis.h); "" = decided from the data
  OrbitOptions orbit;     // --orbit-* flags
  int target_spp = 4;     // --target-spp (filter-jittered; docs/relightable.md)
  int max_side = 0;       // --orbit-size with --cameras: the long side of the targets (0: 800)
  bool quiet = false;
  // --estimate: only the first view is rendered (the probe's); the time the
  // others will take (that view's, each) goes to *remaining_s.
  bool estimate = false;
};

void add_radiance_flags(CLI::App* cmd, RadianceStage* r);

// Renders (or reuses) the targets. Returns 0 with *dataset = OUT/radiance and
// *sh_degree = the PLY's SH degree, or 130 when Ctrl-C stopped it (the views
// rendered so far stay cached for the next run).
int run_radiance_stage(const RadianceStage& r, std::string* dataset, int* sh_degree, double* remaining_s = nullptr);

}  // namespace ptir::cli
