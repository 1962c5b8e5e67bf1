// The reference the traversal tests hold SceneAccel's walks to: every Gaussian evaluated for
// the ray, sorted, cut front to back; and the bit-for-bit comparison of two hit lists.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "ptir/accel/scene_accel.h"

namespace ptir::test {

// Every Gaussian evaluated with peak_response/hit_alpha (the functions the traversal
// evaluates), accepted hits in [tmin, t_end) sorted by (t, id), then the front-to-back
// early stop applied (cut where the composited transmittance falls below min_transmittance).
inline std::vector<GaussianHit> naive_hits(const std::vector<GaussianTraceData>& data, const Ray& r, float t_end,
                                           const CullSettings& cull) {
  std::vector<GaussianHit> hits;
  for (uint32_t i = 0; i < data.size(); ++i) {
    PeakResponse p = peak_response(data[i], r.o, r.d);
    if (!(p.t >= r.tmin) || !(p.t < t_end)) continue;
    float a = hit_alpha(p.d2, data[i].opacity, data[i].accept_d2, cull);
    if (a > 0) hits.push_back({p.t, a, data[i].id});
  }
  std::sort(hits.begin(), hits.end(), [](const GaussianHit& a, const GaussianHit& b) {
    return a.t < b.t || (a.t == b.t && a.id < b.id);
  });
  float T = 1;
  for (size_t i = 0; i < hits.size(); ++i) {
    T *= 1 - hits[i].alpha;
    if (T < cull.min_transmittance) {
      hits.resize(i + 1);
      break;
    }
  }
  return hits;
}

// The same hits, bit for bit, in the same order; `what` names the ray in the failure messages.
inline void expect_same_hits(const std::vector<GaussianHit>& a, const std::vector<GaussianHit>& b,
                             const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].id, b[i].id) << what << " hit " << i;
    EXPECT_EQ(a[i].t, b[i].t) << what << " hit " << i;
    EXPECT_EQ(a[i].alpha, b[i].alpha) << what << " hit " << i;
  }
}

}  // namespace ptir::test
