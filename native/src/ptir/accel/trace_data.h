// What the traversal stores per Gaussian: its trace data in spatial (Morton)
// order, and the proxy box the BVH is built over.
#pragma once

#include <vector>

#include "ptir/accel/gaussian_response.h"
#include "ptir/scene/gaussians.h"

namespace ptir {

// Axis-aligned box (a Gaussian's proxy in the BVH).
struct ProxyBox {
  Vec3 lo, hi;
  bool empty() const { return lo.x > hi.x; }
};

// Builds the per-Gaussian trace data (unit-space transform, opacity, accepted
// radius), sorted along a Morton curve so that Gaussians close in space are close
// in memory; GaussianTraceData::id is the index in the field.
std::vector<GaussianTraceData> make_trace_data(const GaussianField& field, const CullSettings& cull = {});

// The box bounding the region where the Gaussian of `g` can be accepted (its
// accepted ellipsoid, padded); empty when it can never be a hit.
ProxyBox proxy_box(const GaussianField& field, const GaussianTraceData& g);

}  // namespace ptir
