// The facing prior: a surface's albedo does not follow the direction it faces.
//
// Why: under a learnt distant light, a diffuse image is a(x) E(n(x)); any other
// irradiance E'(n) fits it as well with the albedo a E / E', which is the truth
// times a smooth function of the normal. That is the blind case's baked shading
// (the underside too dark and the top too bright where the learnt lower
// hemisphere is too bright; a sky's blue on the upward faces): what the
// per-channel scale alignment cannot forgive, since it varies over the object.
// The images barely say which E is right (cast shadows, interreflections and
// highlights only), so the light stays near its start and the albedo takes the
// shading. Measured (docs/blind_light.md): given the true light, the family's
// held-out albedo is 4.7 dB better.
//
// The prior: regress each channel's log albedo over the Gaussians on the real
// spherical harmonics of their normals up to band 2 (what an irradiance holds,
// Ramamoorthi & Hanrahan 2001), weighted by each Gaussian's area x opacity, and
// penalise the fitted bands 1 and 2 (not the mean: that is the balance's):
//     beta_c = M^-1 X^T W l_c,  M = X^T W X,  P = 1/2 sum_c sum_{k>0} beta_ck^2,
// with X the 9 basis values per Gaussian (bands 1-2 centred on their weighted
// means, so that a field of one facing fits none), W the normalised weights and
// l_c = log a_c.
// Its derivative is dP/dl_ic = w_i x_i^T M^-1 S beta_c (S: the bands 1-2), so
// dP/da_ic = that / a_ic. The image term holds the rendered colour, so what the
// prior takes out of the albedo the light has to take up: it moves the pair
// along the ambiguity toward an albedo uncorrelated with the facing direction.
// A real albedo that does follow the normal (a dark sole, a painted top) pays
// the prior's weight against the data; the weight is the --lambda-albedo-facing.
#pragma once

#include <vector>

#include "ptir/scene/gaussians.h"

namespace ptir {

struct FacingPriorResult {
  double value = 0.0;  // P (before the weight)
  // The normal-correlated part of the log albedo, r g b: sqrt(sum_k beta_ck^2).
  double correlation[3] = {0.0, 0.0, 0.0};
};

// P for the field's albedos; when grad is given (sized like f.albedo), adds
// weight x dP/da to it. Gaussians with no area or opacity do not count; a field
// whose normals span too few directions to fit the bands (a plane) gives 0.
FacingPriorResult albedo_facing_prior(const GaussianField& f, double weight, std::vector<Vec3>* grad);

}  // namespace ptir
