// The camera ray of one sample of a pixel, as every pass over a view draws it
// (render_path, its replay, the light solve's transport pass).
#pragma once

#include <cstdint>

#include "ptir/math/path_sampler.h"
#include "ptir/math/pixel_filter.h"
#include "ptir/math/ray.h"
#include "ptir/scene/camera.h"

namespace ptir {

// The camera ray of sample s of pixel (x, y): its offset from the pixel centre is
// drawn from the pixel filter with numbers keyed on (seed, full-image pixel,
// sample), like the path itself; so a crop, the forward render and the replay all
// draw the same ray. Every sample has weight 1 (filter importance sampling).
inline Ray camera_sample(const Camera& camera, const PixelFilterSampler& filter, uint64_t seed, int x, int y, int s,
                         uint64_t* pixel) {
  *pixel = camera.full_pixel_index(x, y);
  // The camera's own dimension group (no bounce uses this index), stratified over the pixel's samples.
  PathRng jitter(make_path_key(seed, *pixel, uint32_t(s)), ~uint64_t(0), 0);
  return camera.generate_ray(filter.position(x, jitter.at(0)), filter.position(y, jitter.at(1)));
}

}  // namespace ptir
