// The k-buffer of one ray during one traversal round (internal to the traversal).
//
// It keeps the k closest accepted hits seen so far, by (t_peak, id). Once it is
// full, nothing behind its last hit can matter this round, so the ray's tfar
// shrinks to that hit and the BVH prunes behind it. Opacity-aware cut (min_T > 0):
// the buffer also ends at the first hit where T0 * prod(1 - alpha) falls below
// min_T, since the walk stops there. The final content does not depend on the
// order in which the BVH reports candidates.
//
// Hits are appended unsorted while the buffer is neither full nor possibly opaque
// (the product over all its hits, a lower bound of every prefix's, stays above
// min_T): most rounds never sort more than once, at the end.
#pragma once

#include <embree3/rtcore.h>

#include <algorithm>
#include <cstdint>

#include "ptir/accel/scene_accel.h"

namespace ptir {

inline bool hit_before(float t, uint32_t id, const GaussianHit& h) { return t < h.t || (t == h.t && id < h.id); }

struct KBuffer {
  GaussianHit* hits;  // sorted by (t, id) once `sorted`
  int count;
  int k;
  bool sorted;  // hits sorted, T_after and `opaque` valid
  bool opaque;  // the buffer ends at the hit where T fell below min_T
  float T0;     // transmittance in front of the round
  float min_T;  // 0: no opacity cut
  float T_all;  // unsorted: T0 * prod(1 - alpha) over all hits, in arrival order
  float T_after[SceneAccel::kMaxK];  // sorted: T_after[i] = T0 * prod_{j<=i} (1 - alpha_j)

  // Products in another order differ by far less than this factor (64 factors).
  static constexpr float kOrderSlack = 1.0001f;

  void reset(GaussianHit* buffer, int k_, float T0_, float min_T_) {
    hits = buffer;
    count = 0;
    k = k_;
    sorted = false;
    opaque = false;
    T0 = T0_;
    min_T = min_T_;
    T_all = T0_;
  }

  // Offers an accepted hit with t in the round's range and t <= tfar. Shrinks
  // tfar (and forgets a triangle hit behind it: geom_id) once the buffer bounds
  // the round.
  void offer(float t, float alpha, uint32_t id, float& tfar, unsigned& geom_id) {
    if (!sorted) {
      // Append; sort only once the buffer may bound the round.
      hits[count++] = GaussianHit{t, alpha, id};
      T_all *= 1.0f - alpha;
      if (count == k || T_all < min_T * kOrderSlack) {
        make_sorted(tfar);
        shrink(tfar, geom_id);
      }
      return;
    }
    // Drop buffered hits that a triangle found since then hides (the opaque cut,
    // being the last entry, goes first).
    while (count > 0 && hits[count - 1].t > tfar) {
      count--;
      opaque = false;
    }
    // Behind the last entry of a full or opaque buffer: never needed.
    if ((count == k || opaque) && !hit_before(t, id, hits[count - 1])) return;

    // Insert in order (the last entry falls off when full).
    int i = std::min(count, k - 1);
    while (i > 0 && hit_before(t, id, hits[i - 1])) {
      hits[i] = hits[i - 1];
      --i;
    }
    hits[i] = GaussianHit{t, alpha, id};
    if (count < k) count++;
    // Entries before i are not opaque (else this hit would lie behind the cut).
    cut_from(i);
    shrink(tfar, geom_id);
  }

  // After the round, with the ray's final tfar and whether a triangle survived:
  // the sorted hits in front of the triangle. Returns whether hits may remain
  // after the last one (the buffer filled up before the ray became opaque).
  bool finish(bool mesh_hit, float tfar) {
    if (!sorted) make_sorted(tfar);
    if (mesh_hit) {
      while (count > 0 && hits[count - 1].t >= tfar) count--;
      return false;
    }
    return count == k && !opaque;
  }

 private:
  // Opacity cut over the sorted entries from i on: ends the buffer at the first
  // hit where the transmittance falls below min_T.
  void cut_from(int i) {
    opaque = false;
    if (!(min_T > 0.0f)) return;
    float T = i == 0 ? T0 : T_after[i - 1];
    for (int j = i; j < count; ++j) {
      T *= 1.0f - hits[j].alpha;
      T_after[j] = T;
      if (T < min_T) {
        count = j + 1;
        opaque = true;
        return;
      }
    }
  }

  // A full (or opaque) buffer bounds the round: nothing behind its last hit matters now.
  void shrink(float& tfar, unsigned& geom_id) {
    if ((count == k || opaque) && hits[count - 1].t < tfar) {
      tfar = hits[count - 1].t;
      // A triangle found earlier lies behind the new tfar; a later round finds it again.
      geom_id = RTC_INVALID_GEOMETRY_ID;
    }
  }

  // Unsorted -> sorted: drops hits a triangle hides, sorts, cuts.
  void make_sorted(float tfar) {
    // The hits in front of tfar, as (t, id) keys (id biased for a signed compare).
    GaussianHit kept[SceneAccel::kMaxK];
    float key_t[SceneAccel::kMaxK];
    int32_t key_id[SceneAccel::kMaxK];
    int n = 0;
    for (int j = 0; j < count; ++j) {
      if (!(hits[j].t <= tfar)) continue;
      kept[n] = hits[j];
      key_t[n] = hits[j].t;
      key_id[n] = int32_t(hits[j].id ^ 0x80000000u);
      n++;
    }
    // Each hit goes to its rank: how many hits come before it (branch-free; the
    // inner loop vectorises, and n is small). Equal keys (never expected: one hit
    // per Gaussian) would keep their order rather than share a rank.
    for (int i = 0; i < n; ++i) {
      int rank = 0;
      for (int j = 0; j < n; ++j) {
        const bool same_t = key_t[j] == key_t[i];
        rank += (key_t[j] < key_t[i]) | (same_t & (key_id[j] < key_id[i])) | (same_t & (key_id[j] == key_id[i]) & (j < i));
      }
      hits[rank] = kept[i];
    }
    count = n;
    sorted = true;
    cut_from(0);
  }
};

}  // namespace ptir
