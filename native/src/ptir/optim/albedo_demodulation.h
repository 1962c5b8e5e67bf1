// The albedo's start from the splats' own radiance and the start light: demodulation
// (docs/captures.md, "The albedo started from the radiance it must explain").
//
// A splat fitted to the photos (the geometry stage's SH, in the photos' linear units) carries
// per Gaussian the radiance the photos saw, c_i (its SH DC, field_radiance.h). Of a diffuse
// surface c_i = a_i E_i / pi, E_i the irradiance at the Gaussian: so
//   a_i = c_i / (E_i / pi),   E_i / pi = mean over cosine-distributed directions w about n_i of
//   L_in(w) = sum_j T_j alpha_j c_j + T_end L_env(w)
// (the field composited along the ray leaving the Gaussian, its own hit skipped, the start
// environment behind). The bounce light comes from the same fitted radiance, as the inversion's
// indirect field takes it. What the estimate leaves out: the specular part of c_i (F0 = 0.04 at
// the start roughness: the albedo a few hundredths high) and the photos' view dependence (the DC
// is its average).
//
// Why: the inversion learns the albedo in logit space from patches; a dark feature few patches
// cover (a toy's eyes and nose: 0.3 → 0.02 is 3 logit units) stays grey for hundreds of
// iterations, and the fur's albedo starts one grey. Started from a_i, the inversion refines a
// field that already shows the photos.
#pragma once

#include <cstdint>
#include <vector>

#include "ptir/accel/scene_accel.h"
#include "ptir/lights/environment_light.h"
#include "ptir/math/vec.h"

namespace ptir {

struct DemodulationSettings {
  int rays = 64;           // cosine-distributed rays per Gaussian
  float min_albedo = 0.01f, max_albedo = 0.95f;
  uint64_t seed = 0;
};

// Per Gaussian of accel.field() (its normals oriented): the demodulated albedo, clamped to
// [min_albedo, max_albedo]. `radiance`: field_radiance(field) (linear, one per Gaussian).
std::vector<Vec3> demodulated_albedo(const SceneAccel& accel, const std::vector<Vec3>& radiance,
                                     const SceneEnvironment& environment, const DemodulationSettings& s = {});

}  // namespace ptir
