// A neighbourhood term over the Gaussians (issue 52, the blind case): splats of one
// material share albedo, so the albedos' chromaticities chi(a) = a / (a_r + a_g + a_b)
// are pulled together along a k-nearest-neighbour graph of the Gaussian centres.
// Only the chromaticity, not the level: a shadow darkens a surface without changing
// its colour, so a darker neighbour is no licence for a colour difference, and the
// term leaves the shading's intensity to the image loss.
//
//   G = (1 / sum_e w_e) sum_e w_e |chi(a_i) - chi(a_j)|^2   over the graph's edges e = (i, j)
//
// with w_e = exp(-sharpness * mean_c |chi(g_i) - chi(g_j)|) from a per-Gaussian guide
// colour g (sharpness 0: every edge weight 1).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "ptir/math/vec.h"

namespace ptir {

struct AlbedoGraph {
  std::vector<std::array<uint32_t, 2>> edges;  // i < j, each pair once
  std::vector<float> weight;                   // per edge
  double weight_sum = 0.0;
};

// The chromaticity of a colour (negative components clamped to 0; black gives 1/3 each).
Vec3 chromaticity(const Vec3& c);

// The graph of each centre's k nearest other centres (symmetrised), weighted by the guide
// colours' chromaticity at `sharpness` (guide empty or sharpness 0: weight 1).
AlbedoGraph build_albedo_graph(const std::vector<Vec3>& centres, int k, const std::vector<Vec3>& guide,
                               float sharpness);

// G and (if d_albedo) dG/d albedo, written (not accumulated), one Vec3 per Gaussian.
double albedo_graph_term(const AlbedoGraph& graph, const std::vector<Vec3>& albedo, std::vector<Vec3>* d_albedo);

}  // namespace ptir
