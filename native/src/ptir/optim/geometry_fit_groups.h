// The geometry stage's raw parameters (geometry_fit.h), one ParameterGroup per
// kind, each a fixed number of floats per Gaussian, and their activations:
//   position       mu (3)                   as is
//   log scale      s = exp(x) (3)
//   rotation       q = x / |x| (4, w x y z)  normalised on use
//   opacity        sigma = sigmoid(x) (1)
//   SH dc / rest   as is (3; stride - 3)     two groups: 3DGS's two learning rates
//   normal         n = x / |x| (3)           normalised on use
#pragma once

#include <vector>

#include "ptir/optim/parameters.h"
#include "ptir/render/splat_composite.h"
#include "ptir/scene/gaussians.h"

namespace ptir {

struct GeometryFitSettings;

enum FitGroup { kFitPosition, kFitLogScale, kFitRotation, kFitOpacity, kFitShDc, kFitShRest, kFitNormal, kFitGroups };

// Floats per Gaussian of group k for a field of this SH stride.
int fit_group_width(int k, int sh_stride);
ParamKind fit_group_kind(int k);

// Raw values of the field's current parameters, with the settings' learning rates
// (position scaled by the cameras' extent).
std::vector<ParameterGroup> make_fit_groups(const GaussianField& f, const GeometryFitSettings& s, float extent);

// Writes the activated values into the field (its size follows the groups'; the
// material arrays must already have that size).
void apply_fit_groups(const std::vector<ParameterGroup>& groups, GaussianField& f);

// dLoss/d(raw) from the gradients w.r.t. the field's values; non-finite entries become 0.
std::vector<std::vector<float>> fit_raw_gradients(const std::vector<ParameterGroup>& groups, const SplatGradients& g,
                                                  const GaussianField& f);

}  // namespace ptir
