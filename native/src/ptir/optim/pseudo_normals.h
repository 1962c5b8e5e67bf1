// Pseudo-normals of a rendered depth map and the normal-consistency term of the
// geometry stage (geometry_fit.h).
#pragma once

#include "ptir/io/image.h"
#include "ptir/scene/camera.h"

namespace ptir {

// Per pixel, the normal of the surface the depth map describes: the points
// P = o + depth * d of the pixel centres' rays, n = normalize((P(x+r) - P(x-r)) x
// (P(y+r) - P(y-r))), turned to face the camera. A stencil radius r > 1 smooths
// the noise of a blended depth (at 100^2, r = 1 gives 16 degrees of error on
// exact splats). Where the pixel or a stencil neighbour has opacity <= min_opacity,
// or the neighbours' depths differ by more than max_relative_step (an occluding
// edge), the pixel has none (A = 0). Channels X, Y, Z, A.
Image pseudo_normals(const Camera& camera, const Image& depth, const Image& opacity, int radius = 2,
                     float min_opacity = 0.5f, float max_relative_step = 0.1f);

// mean over pixels with a pseudo-normal of (1 - N . N_pseudo), N = normal_sum
// normalised; d_normal_sum (3 channels) gets its gradient times `weight`.
// Returns the unweighted mean (0 without such pixels).
//
// per_hit: the gradient is instead that of the per-hit loss the paper weights by
// the compositing weight, mean over pixels of sum_i w_i (1 - n_i . N_pseudo)
// (front hits, the normal sum's), i.e. dL/dNsum = -N_pseudo: with the weights held
// (the geometry stage's default), every front Gaussian's own normal is pulled
// toward the pixel's pseudo-normal in proportion to its weight, where the
// normalised blend's gradient (p - (N.p) N) / |Nsum| vanishes once the blend agrees
// -- also for a hidden, flipped or low-weight normal inside it, which then stays
// wrong and shows from other views. The returned value is the same mean.
//
// max_cos < 1: only pixels whose normal is further than acos(max_cos) from the
// pseudo-normal get a gradient (outliers: a normal facing elsewhere, not the
// pseudo-normals' own noise).
double normal_consistency(const Image& normal_sum, const Image& pseudo, float weight, Image* d_normal_sum,
                          bool per_hit = false, float max_cos = 2.0f);

}  // namespace ptir
