// The recovered environment with the detail the photos saw (docs/captures.md, "Real
// photos"). The inversion learns a coarse lat-long map (its light: 128x64, ~2.8 degrees
// a texel, ~70 photo pixels at a 30-degree lens), started from the background the
// photos saw (optim/capture_analysis.h). Seen directly behind the object, that map is
// blocks; the photos resolve the same directions 30-70x finer. The output map:
//
//   seen texel (x, y) of the fine map:    seen(x, y) * learnt(X, Y) / start(X, Y)
//   unseen:                               learnt, bilinear at (x, y)
//
// (X, Y) the coarse texel holding the fine one (every map is lat-long over the same
// sphere, Blender's orientation). Where the inversion kept the start, a seen texel is
// the photos' own radiance; where it moved the light, the fine detail follows the
// learnt level (the ratio clamped to [1/4, 4]). The light seen from the object is the
// learnt one up to that detail: each coarse texel's mean is kept.
#pragma once

#include "ptir/io/image.h"

namespace ptir {

// learnt, start: coarse maps of one size (RGB first); seen: fine, RGB + a 4th channel (> 0: seen).
Image env_with_detail(const Image& learnt, const Image& start, const Image& seen);

}  // namespace ptir
