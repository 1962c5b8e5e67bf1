// Virtual cameras around a splat object, for the inversion without photos
// (`ptir optimize --gaussians IN.ply` with no --dataset; docs/relightable.md).
//
// Bounds: opacity-weighted and robust. Splats with opacity below 0.05 do not
// count; per axis the bounds are the 1st and 99th opacity-weighted percentiles of
// the positions (floaters trimmed); the centre is their middle; the radius is the
// 99th weighted percentile of the kept splats' distances to it, plus the 3 sigma
// of their median largest scale (the splats' own extent).
//
// Orbit: every camera looks at the centre from `distance` = radius / sin(fov/2)
// x 1.15, so the whole bounding sphere is in view with a margin and no camera is
// inside it (the distance is at least 2.9 radii at the default 40 degrees). The
// directions follow a golden-angle spiral uniform in sin(elevation) over the
// elevation range about the up axis (OrbitOptions::up: world +z, Blender's
// convention, unless the caller decided another, scene/splat_up_axis.h): every
// part of the range is seen about equally.
//
// Defaults from the splat count N (see docs/relightable.md for the reasoning):
// side = 16 * round(sqrt(N) / 20), clamped to [256, 640] pixels (a splat
// covers a few pixels in the view that sees it); views = 24 + 8 log2(N / 10^4),
// clamped to [24, 96]; elevation -30..75 degrees, or 10..75 for a flat extent
// (the extent along up under a quarter of the horizontal one, each the 1st..99th
// opacity-weighted percentiles: a patch of ground or a relief seen from above).
#pragma once

#include <string>
#include <vector>

#include "ptir/math/vec.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/gaussians.h"

namespace ptir {

struct SplatBounds {
  Vec3 lo, hi;         // the robust box
  Vec3 centre;         // its middle
  float radius = 0;    // the robust bounding sphere's radius about centre
  size_t counted = 0;  // splats that counted (opacity >= 0.05)
};

// Throws ptir::Error when no splat is opaque enough to bound.
SplatBounds robust_splat_bounds(const GaussianField& field);

struct OrbitOptions {
  int views = 0;            // 0: from the splat count
  int size = 0;             // image side in pixels (square views); 0: from the splat count
  float elevation_min = -1000, elevation_max = -1000;  // degrees; -1000: from the extent
  float fov_deg = 40;       // horizontal = vertical field of view
  float distance_scale = 1; // multiplies the distance (< 1 / 1.15 x sin(fov/2) puts cameras inside the sphere)
  Vec3 up{0, 0, 1};         // unit: the axis the elevations are measured about, the views' image up
};

struct OrbitPlan {
  SplatBounds bounds;
  int views = 0, size = 0;
  float elevation_min = 0, elevation_max = 0, fov_deg = 0, distance = 0;
  Vec3 up{0, 0, 1};
  std::vector<Camera> cameras;  // named "orbit_000", ...
};

OrbitPlan plan_orbit(const GaussianField& field, const OrbitOptions& options);

// Camera-to-world of a camera at `eye` looking at `target`, its image up toward
// `up` (camera.h's convention).
Affine look_at(Vec3 eye, Vec3 target, Vec3 up = Vec3(0, 0, 1));

// Two unit vectors that make (e1, e2, up) a right-handed orthonormal frame; for
// +z up they are +x and +y (the orbit's azimuth 0 and 90 degrees).
void horizontal_axes(Vec3 up, Vec3* e1, Vec3* e2);

// The plan as JSON (OUT/views.json): bounds, the chosen numbers and every camera
// (transform_matrix row-major camera-to-world, fl_x, fl_y, cx, cy, w, h).
std::string orbit_plan_json(const OrbitPlan& plan, const std::string& source);

}  // namespace ptir
