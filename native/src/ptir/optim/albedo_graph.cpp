#include "ptir/optim/albedo_graph.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "ptir/core/error.h"

namespace ptir {

Vec3 chromaticity(const Vec3& c) {
  const float r = std::max(0.0f, c.x), g = std::max(0.0f, c.y), b = std::max(0.0f, c.z);
  const float s = r + g + b;
  if (!(s > 0.0f)) return Vec3{1.0f / 3.0f, 1.0f / 3.0f, 1.0f / 3.0f};
  return Vec3{r / s, g / s, b / s};
}

AlbedoGraph build_albedo_graph(const std::vector<Vec3>& centres, int k, const std::vector<Vec3>& guide,
                               float sharpness) {
  if (k < 1) throw Error("the albedo graph needs k >= 1 neighbours");
  if (!guide.empty() && guide.size() != centres.size()) throw Error("the albedo graph's guide needs one colour per Gaussian");
  const size_t n = centres.size();
  const size_t kk = std::min(size_t(k), n > 0 ? n - 1 : 0);
  // Each centre's kk nearest (brute force: the family's fields hold <= 15k splats).
  std::vector<uint32_t> nearest(n * kk);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<std::pair<float, uint32_t>> best;
    for (size_t i = r.begin(); i < r.end(); ++i) {
      best.clear();
      for (size_t j = 0; j < n; ++j) {
        if (j == i) continue;
        const float dx = centres[j].x - centres[i].x, dy = centres[j].y - centres[i].y, dz = centres[j].z - centres[i].z;
        const float d2 = dx * dx + dy * dy + dz * dz;
        if (best.size() < kk) {
          best.emplace_back(d2, uint32_t(j));
          std::push_heap(best.begin(), best.end());
        } else if (d2 < best.front().first) {
          std::pop_heap(best.begin(), best.end());
          best.back() = {d2, uint32_t(j)};
          std::push_heap(best.begin(), best.end());
        }
      }
      for (size_t m = 0; m < best.size(); ++m) nearest[i * kk + m] = best[m].second;
    }
  });
  // Symmetrise: each unordered pair once.
  AlbedoGraph g;
  for (size_t i = 0; i < n; ++i)
    for (size_t m = 0; m < kk; ++m) {
      uint32_t a = uint32_t(i), b = nearest[i * kk + m];
      g.edges.push_back({std::min(a, b), std::max(a, b)});
    }
  std::sort(g.edges.begin(), g.edges.end());
  g.edges.erase(std::unique(g.edges.begin(), g.edges.end()), g.edges.end());
  g.weight.resize(g.edges.size(), 1.0f);
  if (!guide.empty() && sharpness > 0.0f)
    for (size_t e = 0; e < g.edges.size(); ++e) {
      const Vec3 ci = chromaticity(guide[g.edges[e][0]]), cj = chromaticity(guide[g.edges[e][1]]);
      const float mean = (std::abs(ci.x - cj.x) + std::abs(ci.y - cj.y) + std::abs(ci.z - cj.z)) / 3.0f;
      g.weight[e] = std::exp(-sharpness * mean);
    }
  for (float w : g.weight) g.weight_sum += double(w);
  return g;
}

double albedo_graph_term(const AlbedoGraph& graph, const std::vector<Vec3>& albedo, std::vector<Vec3>* d_albedo) {
  if (d_albedo) d_albedo->assign(albedo.size(), Vec3{0.0f, 0.0f, 0.0f});
  if (!(graph.weight_sum > 0.0)) return 0.0;
  double sum = 0.0;
  for (size_t e = 0; e < graph.edges.size(); ++e) {
    const uint32_t i = graph.edges[e][0], j = graph.edges[e][1];
    const Vec3 ci = chromaticity(albedo[i]), cj = chromaticity(albedo[j]);
    const double d[3] = {double(ci.x) - cj.x, double(ci.y) - cj.y, double(ci.z) - cj.z};
    const double w = double(graph.weight[e]) / graph.weight_sum;
    sum += w * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!d_albedo) continue;
    // d chi_c / d a_k = (delta_ck - chi_c) / S (S = r + g + b): dG/da_k = 2 w (d_k - d . chi) / S, opposite for j.
    for (int side = 0; side < 2; ++side) {
      const uint32_t g = side == 0 ? i : j;
      const Vec3& a = albedo[g];
      const Vec3 chi = side == 0 ? ci : cj;
      const double s = double(std::max(0.0f, a.x)) + std::max(0.0f, a.y) + std::max(0.0f, a.z);
      if (!(s > 0.0)) continue;
      const double sign = side == 0 ? 1.0 : -1.0;
      const double dot = d[0] * chi.x + d[1] * chi.y + d[2] * chi.z;
      for (int c = 0; c < 3; ++c)
        if (a[c] > 0.0f) (*d_albedo)[g][c] += float(sign * 2.0 * w * (d[c] - dot) / s);
    }
  }
  return sum;
}

}  // namespace ptir
