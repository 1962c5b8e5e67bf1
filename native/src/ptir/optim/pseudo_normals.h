// Pseudo-normals of a rendered depth map and the normal-consistency term of the
// geometry stage (geometry_fit.h).
#pragma once

#include "ptir/io/image.h"
#include "ptir/scene/camera.h"

namespace ptir {

// Per pixel, the normal of the surface the depth map describes: the points
// P = o + depth * d of the pixel centres' rays, n = normalize((P(x+1) - P(x-1)) x
// (P(y+1) - P(y-1))), turned to face the camera. Where the pixel or a neighbour
// has opacity <= min_opacity, or the neighbours lie at depths more than
// max_relative_step apart (an occluding edge), the pixel has none (A = 0).
// Channels X, Y, Z, A.
Image pseudo_normals(const Camera& camera, const Image& depth, const Image& opacity, float min_opacity = 0.5f,
                     float max_relative_step = 0.1f);

// mean over pixels with a pseudo-normal of (1 - N . N_pseudo), N = normal_sum
// normalised; d_normal_sum (3 channels) gets its gradient times `weight`.
// Returns the unweighted mean (0 without such pixels).
double normal_consistency(const Image& normal_sum, const Image& pseudo, float weight, Image* d_normal_sum);

}  // namespace ptir
