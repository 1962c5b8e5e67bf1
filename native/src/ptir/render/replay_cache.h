// What the replay of an image's samples reuses from their primal render (path
// replay backpropagation without recomputing it; docs/method.md §6): one value
// that render_path fills and render_path_backward reads, for one image or row
// band, handed from the optimiser's primal pass to its replay. Every part is
// optional; a part left empty is recomputed by the replay with the same random
// numbers, so the gradients are the same floats either way
// (tests/native/test_gradient_tile.cpp).
#pragma once

#include <cstdint>
#include <vector>

#include "ptir/math/vec.h"
#include "ptir/transport/walk_store.h"

namespace ptir {

struct ReplayCache {
  // What render_path keeps.
  bool keep_radiance = true;   // each sample's radiance (else recomputed just before its replay)
  bool keep_shadows = true;    // each sample's ray outcomes, 8 bytes a sample (else traced again)
  WalkStore* walks = nullptr;  // the walks the replay would trace again, within the store's budget

  // Kept by render_path, one entry a sample (index (y * width + x) * spp + s); empty: not kept.
  std::vector<Vec3> radiance;
  std::vector<uint64_t> shadows;

  // A cache that keeps only the parts named.
  static ReplayCache radiance_only() { return with(true, false); }
  static ReplayCache shadows_only() { return with(false, true); }
  static ReplayCache walks_only(WalkStore* store) {
    ReplayCache c = with(false, false);
    c.walks = store;
    return c;
  }

 private:
  static ReplayCache with(bool radiance, bool shadows) {
    ReplayCache c;
    c.keep_radiance = radiance;
    c.keep_shadows = shadows;
    return c;
  }
};

}  // namespace ptir
