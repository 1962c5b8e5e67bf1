// The radiance the splats themselves carry: a trained 3DGS field's SH colour is
// what the photos saw of each Gaussian, the outgoing radiance of the surface
// (after `ptir fit`, the geometry stage, refitted to the training images).
// The inversion can take its bounce light from it (IntegratorSettings::
// indirect_from_field): a ray leaving a vertex that meets the splats ends with
// this radiance, composited like the materials, instead of a further vertex
// shaded with the current albedo and light.
//
// Why: the light-albedo split is ambiguous in the direct light (all albedos up,
// the light down) and is pinned only by what scales differently -- the light
// between surfaces, which under a path-traced estimate scales with the albedo's
// square. Taken from the data it is a fixed amount: an albedo level or a light
// shape that does not fit it no longer explains the images. docs/objective.md.
#pragma once

#include <vector>

#include "ptir/math/vec.h"
#include "ptir/scene/gaussians.h"

namespace ptir {

// Per Gaussian: its SH DC colour (3DGS convention 0.5 + C0 f_dc, the view-average
// of the SH, clamped to [0, 1]) decoded from sRGB to linear radiance -- the
// geometry stage fits the SH in display space. Empty when the field has no SH.
// The higher SH degrees are left out: a ray from a vertex sees a Gaussian from
// directions no photo may have seen, where they extrapolate.
std::vector<Vec3> field_radiance(const GaussianField& field);

}  // namespace ptir
