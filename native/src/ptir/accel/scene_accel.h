// One Embree 3 scene holding the Gaussians (user geometry, bounded by the AABB of
// their accepted ellipsoid) and the triangle meshes, and the ordered walk of the
// Gaussian hits along a ray.
//
// Ordered walk: bounded-memory multi-round k-buffer traversal (3dgrut; Embree's
// next_hit tutorial). Each round collects the k closest hits after the last one
// processed, ordered by (t_peak, Gaussian id); when the buffer is full the ray's
// tfar shrinks to the k-th hit so the BVH prunes everything behind it. A triangle
// hit ends the walk: Gaussians whose peak lies behind the mesh are never visited.
//
// Packets: walk_packet() walks up to kMaxPacket coherent rays (neighbouring pixels)
// through one Embree packet traversal per round (rtcIntersect4/8/16), with one
// k-buffer and tfar per lane; each lane gets exactly the hits walk() gives it.
//
// Files: trace_data (what is stored per Gaussian), gaussian_response (the
// response and cull rule: the one formula traversal and reference share),
// kbuffer (one ray's round), round_context + gaussian_intersect (the Embree
// callback, the hot loop), packet_round (a packet's round), scene_accel.cpp.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "ptir/accel/gaussian_response.h"
#include "ptir/accel/trace_data.h"
#include "ptir/core/error.h"
#include "ptir/math/ray.h"
#include "ptir/scene/gaussians.h"
#include "ptir/scene/mesh.h"

namespace ptir {

struct GaussianHit {
  float t;      // t_peak
  float alpha;  // effective opacity, already culled and clamped
  uint32_t id;  // Gaussian index
};

struct MeshHit {
  bool valid = false;
  float t = 0.0f;
  uint32_t mesh = 0;  // index into the meshes given to SceneAccel
  uint32_t prim = 0;  // triangle index
  float u = 0.0f, v = 0.0f;
};

struct TraceStats {
  uint64_t rounds = 0;
  uint64_t hits = 0;        // hits handed to the visitor
  uint64_t candidates = 0;     // Gaussians tested (the BVH reported them for the ray / lane)
  uint64_t packet_rounds = 0;  // packet traversals (walk_packet; `rounds` counts its lanes' rounds)
};

// How a walk ended.
struct WalkEnd {
  bool stopped = false;  // the visitor asked to stop
  MeshHit mesh;          // the mesh that ended the walk (valid only when reached)
};

// Where the time of building a SceneAccel went (seconds): the per-Gaussian trace
// data (Morton order, unit-space transforms), the proxy boxes, and Embree's BVH
// build (Gaussians and meshes; the mesh-only scene included).
struct AccelBuildTimes {
  double trace_data = 0.0, boxes = 0.0, bvh = 0.0;
};

// A test of one accepted hit, made inside the traversal (a plain function and its
// data: Embree's callbacks are C). Make one from a callable with hit_test().
struct HitTest {
  bool (*test)(const void* user, const GaussianHit& hit) = nullptr;
  const void* user = nullptr;
  bool operator()(const GaussianHit& hit) const { return test(user, hit); }
};

// The HitTest calling f (which must outlive it).
template <class F>
HitTest hit_test(const F& f) {
  return HitTest{[](const void* user, const GaussianHit& hit) { return bool((*static_cast<const F*>(user))(hit)); }, &f};
}

struct AccelSettings {
  CullSettings cull;
  int k = 32;  // hits collected per traversal round (1..64); 32: one round for most camera rays
};

class SceneAccel {
 public:
  static constexpr int kMaxK = 64;
  static constexpr int kMaxPacket = 16;  // rays per walk_packet

  SceneAccel(const GaussianField& field, const std::vector<TriangleMesh>& meshes, const AccelSettings& settings = {});
  ~SceneAccel();
  SceneAccel(const SceneAccel&) = delete;
  SceneAccel& operator=(const SceneAccel&) = delete;

  // Calls visit(const GaussianHit&) for every accepted Gaussian hit with
  // ray.tmin <= t_peak < min(ray.tmax, first mesh hit), in (t_peak, id) order,
  // until visit returns false. ray.d must be unit length.
  //
  // stop_when_opaque: the walk itself also stops after the first hit at which the
  // transmittance prod(1 - alpha) of the hits visited falls below
  // cull.min_transmittance, and it prunes the BVH behind that hit while collecting
  // (opacity-aware k-buffer). Only for visitors that consume every hit in order
  // and would stop there anyway (compositing); not for visitors that skip hits.
  //
  // skip: hits for which it returns true are dropped inside the traversal, as if
  // they were not there (they take no k-buffer slot and no transmittance), so a
  // visitor that would pass over them (the surface a ray leaves) can still use
  // stop_when_opaque. It is asked before the hit's alpha is evaluated (the hit it
  // gets has alpha 0), so it must decide on t_peak and the id alone.
  template <class Visit>
  WalkEnd walk(const Ray& ray, Visit&& visit, TraceStats* stats = nullptr, bool stop_when_opaque = false,
               const HitTest* skip = nullptr) const;

  // Whether anything occludes the ray in [ray.tmin, ray.tmax]: a triangle, or an
  // accepted Gaussian hit for which `occludes` returns true. The same answer as
  // walking the hits in order until one occludes (it does not depend on the order),
  // with Embree's occlusion query: it stops at the first occluder met, in any order,
  // and keeps no k-buffer.
  bool occluded(const Ray& ray, const HitTest& occludes) const;

  // walk() for n <= kMaxPacket rays at once: calls visit(int lane, const GaussianHit&)
  // with, for each lane, exactly the hits and order walk(rays[lane], ...) gives
  // (lanes interleave round by round), until visit returns false for that lane;
  // ends[lane] is what walk() would return. For coherent rays: the camera rays of
  // a 4x4 (or 4x2) pixel block trace ~1.8x faster than one by one; incoherent
  // rays (other origins, directions apart) are slower than one by one.
  template <class Visit>
  void walk_packet(const Ray* rays, int n, Visit&& visit, WalkEnd* ends, TraceStats* stats = nullptr,
                   bool stop_when_opaque = false) const;

  // Closest triangle hit in [ray.tmin, ray.tmax], ignoring Gaussians.
  MeshHit closest_mesh(const Ray& ray) const;

  const std::vector<GaussianTraceData>& trace_data() const { return data_; }
  const AccelSettings& settings() const { return settings_; }
  const AccelBuildTimes& build_times() const { return build_times_; }
  const std::vector<TriangleMesh>& meshes() const { return *meshes_; }
  const GaussianField& field() const { return *field_; }

  // One traversal round: the up-to-k closest hits after (t_start, id_start)
  // (id_start = -1 admits t_peak == t_start), sorted; returns the count. Sets *mesh
  // when a triangle lies before every hit beyond the buffer (the walk ends there);
  // *more = true when hits may remain after the last one returned. With
  // min_transmittance > 0 the buffer is cut after the first hit at which T0 times
  // the buffered prefix's transmittance falls below it (then *more = false).
  // skip: as in walk().
  int round(const Ray& ray, float t_start, int64_t id_start, GaussianHit* buffer, MeshHit* mesh, bool* more,
            uint64_t* candidates = nullptr, float T0 = 1.0f, float min_transmittance = 0.0f,
            const HitTest* skip = nullptr) const;

  // One lane of a packet round: its start and, after the round, its sorted hits.
  struct PacketLane {
    float t_start;
    int64_t id_start;
    float T0;       // transmittance of the hits visited so far
    int count;      // hits returned
    bool more;      // hits may remain after the last one
    MeshHit mesh;   // a triangle before every hit beyond the buffer (the walk ends there)
    GaussianHit hits[kMaxK];
  };
  // round() for the lanes of `active` (bit i: rays[i]) together, as one Embree
  // packet traversal; same results per lane as round().
  void round_packet(const Ray* rays, uint32_t active, PacketLane* lanes, float min_transmittance,
                    uint64_t* candidates = nullptr, uint64_t* packet_rounds = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  const GaussianField* field_;
  const std::vector<TriangleMesh>* meshes_;
  AccelSettings settings_;
  std::vector<GaussianTraceData> data_;
  AccelBuildTimes build_times_;
};

template <class Visit>
WalkEnd SceneAccel::walk(const Ray& ray, Visit&& visit, TraceStats* stats, bool stop_when_opaque,
                         const HitTest* skip) const {
  GaussianHit buffer[kMaxK];
  float t_start = ray.tmin;
  int64_t id_start = -1;
  const float min_T = stop_when_opaque ? settings_.cull.min_transmittance : 0.0f;
  float T = 1.0f;  // transmittance of the hits visited so far
  WalkEnd end;
  for (;;) {
    MeshHit mesh;
    bool more = false;
    int n = round(ray, t_start, id_start, buffer, &mesh, &more, stats ? &stats->candidates : nullptr, T, min_T, skip);
    if (stats) stats->rounds++;
    // Hand this round's hits to the visitor in order.
    for (int i = 0; i < n; ++i) {
      if (stats) stats->hits++;
      T *= 1.0f - buffer[i].alpha;
      if (!visit(buffer[i]) || T < min_T) {
        end.stopped = true;
        return end;
      }
    }
    if (mesh.valid) {
      end.mesh = mesh;
      return end;
    }
    if (!more) return end;
    // Next round starts just after the last hit processed.
    t_start = buffer[n - 1].t;
    id_start = buffer[n - 1].id;
  }
}

template <class Visit>
void SceneAccel::walk_packet(const Ray* rays, int n, Visit&& visit, WalkEnd* ends, TraceStats* stats,
                             bool stop_when_opaque) const {
  if (n < 0 || n > kMaxPacket) throw Error("walk_packet: at most " + std::to_string(kMaxPacket) + " rays");
  PacketLane lanes[kMaxPacket];
  const float min_T = stop_when_opaque ? settings_.cull.min_transmittance : 0.0f;
  uint32_t active = (1u << n) - 1u;
  for (int l = 0; l < n; ++l) {
    lanes[l].t_start = rays[l].tmin;
    lanes[l].id_start = -1;
    lanes[l].T0 = 1.0f;
    ends[l] = WalkEnd();
  }
  while (active) {
    round_packet(rays, active, lanes, min_T, stats ? &stats->candidates : nullptr, stats ? &stats->packet_rounds : nullptr);
    // Per lane, as in walk(): hand the round's hits over in order, then end or go on.
    for (int l = 0; l < n; ++l) {
      if (!(active >> l & 1u)) continue;
      PacketLane& lane = lanes[l];
      bool done = false;
      if (stats) stats->rounds++;
      for (int i = 0; i < lane.count && !done; ++i) {
        if (stats) stats->hits++;
        lane.T0 *= 1.0f - lane.hits[i].alpha;
        if (!visit(l, static_cast<const GaussianHit&>(lane.hits[i])) || lane.T0 < min_T) {
          ends[l].stopped = true;
          done = true;
        }
      }
      if (!done && lane.mesh.valid) {
        ends[l].mesh = lane.mesh;
        done = true;
      }
      if (done || !lane.more) {
        active &= ~(1u << l);
        continue;
      }
      lane.t_start = lane.hits[lane.count - 1].t;
      lane.id_start = lane.hits[lane.count - 1].id;
    }
  }
}

}  // namespace ptir
