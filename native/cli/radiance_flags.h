// The switches of `ptir optimize` without --dataset (pipeline/radiance_stage.h:
// targets from the splats' own radiance, docs/relightable.md).
#pragma once

#include <CLI/CLI.hpp>

#include "ptir/pipeline/radiance_stage.h"

namespace ptir::cli {

inline void add_radiance_flags(CLI::App* cmd, pipeline::RadianceStage* r) {
  const char* group = "Without --dataset: targets from the splats' own radiance (docs/relightable.md)";
  cmd->add_option("--cameras", r->cameras,
                  "a 3DGS output's cameras.json (or its folder): render the targets from these poses instead of an orbit "
                  "(scenes, not only objects)")
      ->group(group);
  cmd->add_option("--up", r->up,
                  "the splats' up axis: x, y, z, -x, -y, -z or X,Y,Z (default: decided from the data: the cameras, "
                  "the SH, the file's convention; recorded in OUT/views.json)")
      ->group(group);
  cmd->add_option("--orbit-views", r->orbit.views, "virtual views around the splats (0: from the splat count, 24..96)")
      ->group(group);
  cmd->add_option("--orbit-size", r->orbit.size,
                  "side of the square virtual views in pixels (0: from the splat count, 256..640); with --cameras the "
                  "targets' long side (0: 800)")
      ->group(group);
  cmd->add_option("--orbit-elevation", r->orbit.elevation_min, "lowest camera elevation in degrees (default -30, 10 for flat extents)")
      ->group(group);
  cmd->add_option("--orbit-elevation-max", r->orbit.elevation_max, "highest camera elevation in degrees (default 75)")
      ->group(group);
  cmd->add_option("--orbit-fov", r->orbit.fov_deg, "the virtual cameras' field of view in degrees")
      ->capture_default_str()
      ->group(group);
  cmd->add_option("--orbit-distance", r->orbit.distance_scale,
                  "scale of the orbit's distance (1: the bounding sphere fills the view with a margin; a scale that "
                  "brings the cameras inside the bounds is refused by nothing but warned about)")
      ->capture_default_str()
      ->group(group);
  cmd->add_option("--target-spp", r->target_spp, "filter-jittered samples per pixel of each radiance target")
      ->capture_default_str()
      ->group(group);
}

}  // namespace ptir::cli
