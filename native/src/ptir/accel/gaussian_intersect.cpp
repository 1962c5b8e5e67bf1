// The Embree intersect callback of the Gaussians and the evaluation of the
// Gaussians it queues: the hot loop of the traversal.
#include <immintrin.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "ptir/accel/round_context.h"

// Code the evaluation needs inlined into its per-ISA variants (see evaluate_queue).
#define PTIR_INLINE inline __attribute__((always_inline))

namespace ptir {

namespace {

// Whether a peak at t lies after the round's start (t_start, id_start): ties at
// t_start go by Gaussian id. NaN never does.
PTIR_INLINE bool after_start(float t, uint32_t id, float t_start, int64_t id_start) {
  return t > t_start || (t == t_start && int64_t(id) > id_start);
}

// One Gaussian against one ray.
PTIR_INLINE void intersect_one(RoundContext* rc, RTCRayHit* rh, const GaussianTraceData& g) {
  RTCRay& ray = rh->ray;
  rc->candidates++;
  // Peak along the ray: after the round's start, not behind tfar.
  float oux, ouy, ouz, dd, od, cc, t, d2;
  unit_origin(g, ray.org_x, ray.org_y, ray.org_z, oux, ouy, ouz);
  peak_parts(g, oux, ouy, ouz, ray.dir_x, ray.dir_y, ray.dir_z, dd, od, cc);
  if (surely_outside(dd, cc, g.accept_d2)) return;
  peak_from_parts(dd, od, cc, t, d2);
  if (!after_start(t, g.id, rc->t_start[0], rc->id_start[0]) || !(t <= ray.tfar)) return;
  // Cull on the squared distance at the peak (hit_alpha's test), then the skip
  // (a fifth of a spawned ray's candidates: the surface it leaves), and exp only
  // for the hits that remain.
  if (!(d2 <= g.accept_d2)) return;
  if (rc->skip && (*rc->skip)(GaussianHit{t, 0.0f, g.id})) return;
  const float alpha = accepted_alpha(d2, g.opacity, rc->cull);
  if (alpha <= 0.0f) return;
  rc->buffer[0].offer(t, alpha, g.id, ray.tfar, rh->hit.geomID);
}

// A packet is evaluated in chunks of W rays, as GCC vectors of W lanes.
template <int W>
struct Chunk;
template <>
struct Chunk<4> {
  typedef float Floats __attribute__((vector_size(16)));
  typedef int Ints __attribute__((vector_size(16)));
};
template <>
struct Chunk<8> {
  typedef float Floats __attribute__((vector_size(32)));
  typedef int Ints __attribute__((vector_size(32)));
};

// Bit i set where lane i is non-zero (SSE2 movemask, 4 lanes at a time), and back.
PTIR_INLINE unsigned lane_bits(Chunk<4>::Ints v) {
  return unsigned(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(__m128i(v), _mm_setzero_si128())))) ^ 0xFu;
}
PTIR_INLINE unsigned lane_bits(Chunk<8>::Ints v) {
  Chunk<4>::Ints lo, hi;
  std::memcpy(&lo, &v, sizeof lo);
  std::memcpy(&hi, reinterpret_cast<const char*>(&v) + sizeof lo, sizeof hi);
  return lane_bits(lo) | lane_bits(hi) << 4;
}

template <class Ints>
PTIR_INLINE Ints lanes_of(uint32_t bits) {
  Ints lane_bit;
  for (int i = 0; i < int(sizeof(Ints) / 4); ++i) lane_bit[i] = 1 << i;
  return (lane_bit & int(bits)) != 0;
}

template <class V>
PTIR_INLINE void load(V& v, const void* p) {
  std::memcpy(&v, p, sizeof v);
}

// One Gaussian against the rays [first, first + W) of a packet of N: the peaks
// (and alphas) of every lane at once, with the same arithmetic as for one ray,
// then the k-buffers of the lanes (of `lanes`) that accept it. `ou`: the origin
// in the Gaussian's unit space when the lanes share it (else null).
template <int N, int W>
PTIR_INLINE void intersect_chunk(RoundContext* rc, float* soa, unsigned* geom_id, int first, uint32_t lanes,
                                 const GaussianTraceData& g, const float* ou) {
  using Floats = typename Chunk<W>::Floats;
  using Ints = typename Chunk<W>::Ints;
  Ints ok = lanes_of<Ints>(lanes >> first);

  // The SoA packet (RTCRayHitN): org_x, org_y, org_z, tnear, dir_x, dir_y, dir_z, time, tfar, ...
  float* tfar = soa + 8 * N + first;
  Floats dx, dy, dz, far, start;
  load(dx, soa + 4 * N + first), load(dy, soa + 5 * N + first), load(dz, soa + 6 * N + first);
  load(far, tfar), load(start, rc->t_start + first);

  // Peaks of all lanes; candidates in range and inside the accepted region.
  Floats t, d2;
  if (ou) {
    peak_from_unit_origin(g, ou[0], ou[1], ou[2], dx, dy, dz, t, d2);
  } else {
    Floats ox, oy, oz;
    load(ox, soa + 0 * N + first), load(oy, soa + 1 * N + first), load(oz, soa + 2 * N + first);
    peak_t_d2(g, ox, oy, oz, dx, dy, dz, t, d2);
  }
  ok &= (t >= start) & (t <= far) & (d2 <= g.accept_d2);
  unsigned accepted = lane_bits(ok);
  if (!accepted) return;
  const Floats alpha = accepted_alpha(d2, g.opacity, rc->cull);

  // Per accepted lane: the tie rule at the round's start, then its k-buffer.
  for (; accepted; accepted &= accepted - 1) {
    const int i = __builtin_ctz(accepted), lane = first + i;
    if (after_start(t[i], g.id, rc->t_start[lane], rc->id_start[lane]) && alpha[i] > 0.0f)
      rc->buffer[lane].offer(t[i], alpha[i], g.id, tfar[i], geom_id[lane]);
  }
}

// One Gaussian against the rays `lanes` of a packet of N, W lanes at a time.
template <int N, int W>
PTIR_INLINE void intersect_packet(RoundContext* rc, RTCRayHitN* rayhit, uint32_t lanes, const GaussianTraceData& g) {
  constexpr int C = N < W ? N : W;
  float* soa = reinterpret_cast<float*>(rayhit);
  unsigned* geom_id = &RTCHitN_geomID(RTCRayHitN_HitN(rayhit, N), N, 0);
  rc->candidates += unsigned(__builtin_popcount(lanes));
  // Camera rays share their origin: its unit-space image is computed once.
  float ou[3];
  if (rc->shared_origin) unit_origin(g, rc->origin[0], rc->origin[1], rc->origin[2], ou[0], ou[1], ou[2]);
  for (int first = 0; first < N; first += C)
    if ((lanes >> first) & ((1u << C) - 1u))
      intersect_chunk<N, C>(rc, soa, geom_id, first, lanes, g, rc->shared_origin ? ou : nullptr);
}

// The queued Gaussians against the packet, W lanes at a time.
template <int W>
PTIR_INLINE void evaluate(RoundContext* rc, void* rayhit) {
  // A few Gaussians ahead: their loads overlap the evaluation of this one.
  constexpr int kAhead = 4;
  const int n = rc->queued;
  for (int i = 0; i < std::min(n, kAhead); ++i) __builtin_prefetch(rc->data + rc->queue[i]);
  auto* rh = static_cast<RTCRayHitN*>(rayhit);
  for (int i = 0; i < n; ++i) {
    if (i + kAhead < n) __builtin_prefetch(rc->data + rc->queue[i + kAhead]);
    const GaussianTraceData& g = rc->data[rc->queue[i]];
    const uint32_t lanes = rc->queue_lanes[i];
    switch (rc->lanes) {
      case 4: intersect_packet<4, W>(rc, rh, lanes, g); break;
      case 8: intersect_packet<8, W>(rc, rh, lanes, g); break;
      case 16: intersect_packet<16, W>(rc, rh, lanes, g); break;
    }
  }
  rc->queued = 0;
}

// One variant per instruction set, chosen at run time: the build stays portable
// (SSE2, 4 lanes at once) and AVX2 machines evaluate 8 lanes at once. Every
// variant runs the same IEEE operations per lane (no FMA): the same results.
void evaluate_sse2(RoundContext* rc, void* rayhit) { evaluate<4>(rc, rayhit); }
__attribute__((target("avx2"))) void evaluate_avx2(RoundContext* rc, void* rayhit) { evaluate<8>(rc, rayhit); }

bool has_avx2() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
}

}  // namespace

void evaluate_queue(RoundContext* rc, void* rayhit) {
  static const bool avx2 = has_avx2();
  if (avx2 && rc->lanes > 4) evaluate_avx2(rc, rayhit);
  else evaluate_sse2(rc, rayhit);
}

void gaussian_intersect(const RTCIntersectFunctionNArguments* args) {
  auto* rc = reinterpret_cast<RoundContext*>(args->context);
  if (args->N == 1) {
    // One ray: evaluate now (it prunes the rest of the traversal soonest), and
    // start loading the Gaussians next to this one in Morton order, which the
    // BVH tends to report next.
    if (!args->valid[0]) return;
    const GaussianTraceData& g = rc->data[args->primID];
    const uintptr_t at = reinterpret_cast<uintptr_t>(&g);
    __builtin_prefetch(reinterpret_cast<const void*>(at + sizeof(g)));
    __builtin_prefetch(reinterpret_cast<const void*>(at + 2 * sizeof(g)));
    __builtin_prefetch(reinterpret_cast<const void*>(at - sizeof(g)));
    intersect_one(rc, reinterpret_cast<RTCRayHit*>(args->rayhit), g);
    return;
  }
  // A packet: queue, with the lanes Embree reports it for, then evaluate in
  // batches. A coherent traversal walks the lanes of each octant of directions
  // separately: a Gaussian may come once per octant, each time for other lanes.
  // With one octant it comes once, and is evaluated for every lane (those Embree
  // leaves out have their tfar in front of it, and reject it).
  uint32_t lanes = rc->active;
  if (!rc->one_octant) {
    lanes = 0;
    for (unsigned i = 0; i < args->N; i += 4) {
      Chunk<4>::Ints v;
      load(v, args->valid + i);
      lanes |= lane_bits(v) << i;
    }
  }
  rc->queue[rc->queued] = args->primID;
  rc->queue_lanes[rc->queued++] = lanes;
  if (rc->queued == RoundContext::kQueue) evaluate_queue(rc, args->rayhit);
}

void gaussian_occluded(const RTCOccludedFunctionNArguments* args) {
  auto* oc = reinterpret_cast<OcclusionContext*>(args->context);
  const GaussianTraceData& g = oc->data[args->primID];
  // rtcOccluded1 asks for one ray; the loop serves any width all the same.
  for (unsigned i = 0; i < args->N; ++i) {
    if (!args->valid[i]) continue;
    float& tfar = RTCRayN_tfar(args->ray, args->N, i);
    float oux, ouy, ouz, dd, od, cc, t, d2;
    unit_origin(g, RTCRayN_org_x(args->ray, args->N, i), RTCRayN_org_y(args->ray, args->N, i),
                RTCRayN_org_z(args->ray, args->N, i), oux, ouy, ouz);
    peak_parts(g, oux, ouy, ouz, RTCRayN_dir_x(args->ray, args->N, i), RTCRayN_dir_y(args->ray, args->N, i),
               RTCRayN_dir_z(args->ray, args->N, i), dd, od, cc);
    if (surely_outside(dd, cc, g.accept_d2)) continue;
    peak_from_parts(dd, od, cc, t, d2);
    // The range of walk()'s first round: t_peak in [t_min, tfar] (NaN never).
    if (!(t >= oc->t_min) || !(t <= tfar)) continue;
    const float alpha = hit_alpha(d2, g.opacity, g.accept_d2, oc->cull);
    if (alpha <= 0.0f) continue;
    if ((*oc->occludes)(GaussianHit{t, alpha, g.id})) tfar = -INFINITY;
  }
}

}  // namespace ptir
