// Adjoint of the primary-hit material maps (albedo, roughness AOVs at pixel
// centres), for the regularisers that act on them (edge-aware TV, prior maps).
#pragma once

#include "ptir/render/aov.h"
#include "ptir/render/material_maps.h"
#include "ptir/transport/gradients.h"

namespace ptir {

// Pushes d_albedo (>= 3 channels) and/or d_roughness (>= 1 channel), each the
// size of the camera's image (either may be null), to what each pixel centre's
// primary interaction is made of: its Gaussians with normalised weights w_i / O
// (the picked one in discrete mode), or the mesh material when the ray found no
// valid Gaussian interaction. Adds to `grads`. Deterministic and thread-count independent like render_path_backward.
// With `walks` (what render_material_maps kept for this camera and settings) each
// pixel's interaction is rebuilt from its recorded hits, nothing traced: the same floats.
void render_aov_backward(const SceneAccel& accel, const Camera& camera, const AovSettings& settings,
                         const Image* d_albedo, const Image* d_roughness, SceneGradients& grads,
                         const MaterialMapWalks* walks = nullptr);

}  // namespace ptir
