#include "ptir/accel/trace_data.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace ptir {

namespace {

// Smallest scale relative to the largest one, so flat Gaussians keep a finite
// unit-space transform (their thickness stays far below any pixel).
constexpr float kMinScaleRatio = 1e-6f;
constexpr float kMinScale = 1e-12f;
// The proxy box is padded so hits exactly on the accepted boundary survive rounding.
constexpr float kBoundPad = 1.001f;

// Spreads the low 10 bits of v to every third bit (Morton code helper).
uint32_t spread_bits(uint32_t v) {
  v &= 0x3FF;
  v = (v | (v << 16)) & 0x030000FF;
  v = (v | (v << 8)) & 0x0300F00F;
  v = (v | (v << 4)) & 0x030C30C3;
  v = (v | (v << 2)) & 0x09249249;
  return v;
}

// Gaussian indices sorted along a Morton curve over the field's bounds, so that
// Gaussians close in space are close in memory: a ray's candidates then share
// cache lines (the traversal is bound by memory latency, not arithmetic).
std::vector<uint32_t> morton_order(const GaussianField& field) {
  Vec3 lo(INFINITY), hi(-INFINITY);
  for (const Vec3& p : field.position) {
    lo = vmin(lo, p);
    hi = vmax(hi, p);
  }
  Vec3 extent = vmax(hi - lo, Vec3(1e-20f));
  std::vector<std::pair<uint32_t, uint32_t>> keys(field.size());
  for (size_t i = 0; i < field.size(); ++i) {
    Vec3 q = (field.position[i] - lo) / extent * 1023.0f;
    uint32_t code = (spread_bits(uint32_t(q.x)) << 2) | (spread_bits(uint32_t(q.y)) << 1) | spread_bits(uint32_t(q.z));
    keys[i] = {code, uint32_t(i)};
  }
  std::sort(keys.begin(), keys.end());
  std::vector<uint32_t> order(field.size());
  for (size_t i = 0; i < keys.size(); ++i) order[i] = keys[i].second;
  return order;
}

}  // namespace

std::vector<GaussianTraceData> make_trace_data(const GaussianField& field, const CullSettings& cull) {
  std::vector<uint32_t> order = morton_order(field);
  std::vector<GaussianTraceData> data(field.size());
  for (size_t slot = 0; slot < field.size(); ++slot) {
    const uint32_t i = order[slot];
    Mat3 r = field.rotation_matrix(i);
    Vec3 s = field.scale[i];
    float s_floor = std::max(kMinScale, kMinScaleRatio * max_component(s));
    s = vmax(s, Vec3(s_floor));
    // Rows of S^-1 R^T are the local axes divided by their scales.
    GaussianTraceData& g = data[slot];
    g.mu = field.position[i];
    g.opacity = field.opacity[i];
    g.to_unit = Mat3::from_rows(r.col(0) / s.x, r.col(1) / s.y, r.col(2) / s.z);
    g.accept_d2 = accept_radius_sq(field.opacity[i], cull);
    g.id = i;
  }
  return data;
}

ProxyBox proxy_box(const GaussianField& field, const GaussianTraceData& g) {
  ProxyBox b{Vec3(1.0f), Vec3(-1.0f)};
  if (g.accept_d2 < 0.0f) return b;
  const float radius = std::sqrt(g.accept_d2) * kBoundPad;
  // Half extent along world axis j of the ellipsoid R diag(radius * s): radius * |row_j(R S)|.
  Mat3 r = field.rotation_matrix(g.id);
  Vec3 s = field.scale[g.id];
  Vec3 ext;
  for (int j = 0; j < 3; ++j) ext[j] = radius * length(r.row(j) * s);
  b.lo = g.mu - ext;
  b.hi = g.mu + ext;
  return b;
}

}  // namespace ptir
