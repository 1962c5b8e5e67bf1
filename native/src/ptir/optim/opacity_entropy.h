// The opacity-entropy term of the geometry stage (geometry_fit.h): the mean binary
// entropy of the Gaussians' opacities,
//   H = mean_i [ -sigma_i ln sigma_i - (1 - sigma_i) ln(1 - sigma_i) ],
//   dH/dsigma_i = ln((1 - sigma_i) / sigma_i) / N,
// which pushes each opacity toward 0 (then pruned) or 1 (SuGaR's regulariser). The
// photometric loss alone leaves a fitted field a cloud of semi-transparent splats
// (median opacity 0.2 on the perturbed sample) whose every pixel blends normals
// from several depths; a surface-like field shades with its front layer's normals.
#pragma once

#include <vector>

namespace ptir {

// Returns H; adds weight * dH/dsigma to d_sigma (sized like sigma) when given.
// sigma is clamped to [1e-6, 1 - 1e-6] (the gradient stays finite).
double opacity_entropy(const std::vector<float>& sigma, float weight, std::vector<float>* d_sigma);

}  // namespace ptir
