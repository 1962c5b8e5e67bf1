// A view's pixels as linear functions of the lat-long environment (for the light
// solve, optim/light_solve.h).
//
// With the materials fixed, a path sample's radiance is linear in the
// environment's radiance: L = sum_j w_j * Le(d_j) + (emitters' part), one term
// per environment lookup of the path (next-event estimation and escapes, each
// MIS-weighted), w_j = throughput x MIS weight / pdf -- exactly the adjoint the
// path replay hands the lookup when dLoss/dL = 1 (PathTracer::sample_adjoint),
// which is how they are found: one routine, so they can never disagree with the
// gradients. Sampling densities and MIS weights are those of the environment the
// tracer holds; the estimate is unbiased for any other radiance Le put in.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "ptir/core/render_control.h"
#include "ptir/math/vec.h"
#include "ptir/transport/path_tracer.h"

namespace ptir {

// One environment lookup of a pixel's samples: the texel (y * width + x of the
// lat-long map) and its weight w per channel, divided by the samples averaged.
struct EnvLookup {
  uint32_t texel;
  Vec3 weight;
};

// One pixel, its samples split in two independent halves (even and odd sample
// indices): the mean radiance and coverage of each half, and their lookups, so
// that for each half L = sum weight * Le(texel) + what the emitters add.
struct EnvTransportPixel {
  int x = 0, y = 0;
  Vec3 L[2];
  float coverage[2] = {0.0f, 0.0f};
  std::vector<EnvLookup> lookups[2];
};

// Renders `camera` at `settings` (spp >= 2) and calls visit(band, pixel) for every
// pixel: bands of `band_rows` rows run in parallel, the pixels of a band in row
// order, so per-band sums are deterministic. The scene's environment must be a
// lat-long map (lights/environment.h); throws Error otherwise. Cancellable.
void render_env_transport(const PathTracer& tracer, const Camera& camera, const IntegratorSettings& settings,
                          int band_rows, const std::function<void(int band, const EnvTransportPixel& pixel)>& visit,
                          const RenderControl& control = {});

}  // namespace ptir
