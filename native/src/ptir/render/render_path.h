// Path-traced images: spp samples per pixel (jittered in the pixel, keyed on
// (seed, pixel, sample)), averaged; TBB over tiles.
#pragma once

#include "ptir/core/render_control.h"
#include "ptir/io/image.h"
#include "ptir/transport/path_tracer.h"

namespace ptir {

// RGBA, linear radiance; A = fraction of samples whose camera ray found a surface.
Image render_path(const PathTracer& tracer, const Camera& camera, const IntegratorSettings& settings,
                  const RenderControl& control = {}, PathStats* stats = nullptr);

}  // namespace ptir
