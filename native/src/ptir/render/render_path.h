// Path-traced images: spp samples per pixel (offsets drawn from the pixel filter,
// keyed on (seed, pixel, sample)), averaged with weight 1; TBB over tiles.
#pragma once

#include <vector>

#include "ptir/core/render_control.h"
#include "ptir/io/image.h"
#include "ptir/render/replay_cache.h"
#include "ptir/transport/gradients.h"
#include "ptir/transport/path_tracer.h"

namespace ptir {

struct TileReduceStats;

// RGBA, linear radiance; A = fraction of samples whose camera ray found a surface.
// cache (optional): receives what the samples' replay reuses (replay_cache.h: each
// sample's radiance, ray outcomes and, within the store's budget, walks) for a
// later render_path_backward with the same camera and settings.
// transparent_film (Cycles' Film > Transparent): samples whose camera ray finds no
// surface add nothing to RGB, so RGB is premultiplied by the coverage A.
// first_sample: the pixels' sample indices are first_sample .. first_sample + spp - 1
// (a progressive render adds passes of the same sequence: the mean of passes
// [0, a) and [a, b) weighted by their counts is the b-sample render, up to float rounding).
Image render_path(const PathTracer& tracer, const Camera& camera, const IntegratorSettings& settings,
                  const RenderControl& control = {}, PathStats* stats = nullptr, ReplayCache* cache = nullptr,
                  bool transparent_film = false, uint32_t first_sample = 0);

// The film's alpha as an image file holds it (docs/alpha.md: RGBA is associated,
// RGB premultiplied by A). A transparent film's RGB is premultiplied by the
// coverage A already, and so is an opaque film's when the scene has no
// environment (escaping rays add nothing). An opaque film that sees the
// environment behind the objects is an opaque picture: A becomes 1, as Cycles
// writes it (its coverage would claim a transparency the RGB does not have).
void set_film_alpha(Image& rgba, bool transparent_film, bool environment_seen);

// Path replay backpropagation of a whole image: d_image (same size as the image,
// >= 3 channels: the adjoint dLoss/dI of each pixel's RGB) is pushed through every
// sample of every pixel with a non-zero adjoint, with the same random numbers as
// render_path; parameter adjoints are ADDED to `grads` (sized by zeros_like).
// What `cache` (filled by render_path with the same camera and settings) holds is
// read instead of recomputed: each sample's primal radiance (else computed just
// before its replay), its shadow-ray outcomes (else traced again) and its kept
// walks (else walked again): the same decisions and floats, bit for bit. Nothing
// per vertex is stored, so memory does not grow with bounces.
// Pixels are replayed in fixed tiles (16 x 16 on large images), each into a sparse buffer of the
// parameters it touched, added in tile order (render/tile_reduce.h): the result
// is deterministic for a seed and the same on any thread count, and memory does
// not grow with the thread count.
void render_path_backward(const PathTracer& tracer, const Camera& camera, const IntegratorSettings& settings,
                          const Image& d_image, SceneGradients& grads, const RenderControl& control = {},
                          const ReplayCache* cache = nullptr, TileReduceStats* tile_stats = nullptr);

}  // namespace ptir
