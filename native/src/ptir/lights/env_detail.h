// The recovered environment with the detail the photos saw (docs/captures.md, "Real
// photos"). The inversion learns a coarse lat-long map (its light: 128x64, ~2.8 degrees
// a texel, ~70 photo pixels at a 30-degree lens), started from the background the
// photos saw (optim/capture_analysis.h). Seen directly behind the object, that map is
// blocks; the photos resolve the same directions 30-70x finer. The output map:
//
//   seen texel (x, y) of the fine map:    seen(x, y), the photos' own radiance
//   unseen:                               learnt, bilinear at (x, y)
//
// (every map is lat-long over the same sphere, Blender's orientation). What the photos
// saw in a direction is the best prediction of what another photo sees there: the
// inversion's change of a seen texel is its light drifting to explain the object (a
// random walk of each coarse texel over a few hundred patches), not a change of the
// wall. Measured on the plush dog (docs/captures.md, "The background the photos saw"):
// the previous rule, seen(x, y) x learnt(X, Y) / start(X, Y), drew the background as
// blocks of that drift, 1.4 dB under the photos' own radiance on the held-out photos'
// background, and the object's pixels under either map score the same.
#pragma once

#include "ptir/io/image.h"

namespace ptir {

// learnt: the coarse map (RGB first); seen: fine, RGB + a 4th channel (> 0: seen).
Image env_with_detail(const Image& learnt, const Image& seen);

}  // namespace ptir
