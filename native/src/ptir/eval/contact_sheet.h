// Contact sheets: a grid of display images (ground truth | ours | error per row)
// written as one PNG, so a result can be judged at a glance.
#pragma once

#include <vector>

#include "ptir/io/image.h"
#include "ptir/math/vec.h"

namespace ptir::eval {

// Display tiles are RGB in [0, 1], already in display space (write with Encoding::Data).

// Error heat map of a per-pixel error e >= 0: t = e / full_scale clamped to [0, 1]
// through a black-purple-orange-yellow ramp; pixels where `show` (optional,
// 1 channel) is <= 0.5 are `background`.
Image heatmap(const Image& error, float full_scale, const Image* show = nullptr, Vec3 background = Vec3(1.0f));

// Per-pixel mean absolute difference over the first three channels.
Image abs_difference(const Image& a, const Image& b);

// Per-pixel angle (degrees) between two normal images (0 where either is zero).
Image angle_difference(const Image& a, const Image& b);

// A grey image shown as RGB (first channel), composited over `background` by
// alpha (optional 1-channel or last channel).
Image grey_to_rgb(const Image& grey, const Image* alpha = nullptr, Vec3 background = Vec3(1.0f));

// Normals (3 channels in [-1, 1]) shown as 0.5 + 0.5 n over `background` by alpha.
Image normals_to_rgb(const Image& normal, const Image* alpha = nullptr, Vec3 background = Vec3(1.0f));

// Rows of tiles (all of the same size) into one image: `scale` x nearest-neighbour
// magnification, `gap` pixels of `gap_colour` between and around tiles.
Image contact_sheet(const std::vector<std::vector<Image>>& rows, int scale = 1, int gap = 2,
                    Vec3 gap_colour = Vec3(0.15f));

}  // namespace ptir::eval
