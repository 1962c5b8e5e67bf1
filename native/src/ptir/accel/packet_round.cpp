// One traversal round of a packet of rays: SceneAccel::round_packet.
#include <embree3/rtcore.h>

#include <cmath>
#include <string>

#include "ptir/accel/round_context.h"

namespace ptir {

namespace {

constexpr unsigned kNoGeometry = RTC_INVALID_GEOMETRY_ID;

inline void intersect(const int* valid, RTCScene scene, RTCIntersectContext* ctx, RTCRayHit4* rh) {
  rtcIntersect4(valid, scene, ctx, rh);
}
inline void intersect(const int* valid, RTCScene scene, RTCIntersectContext* ctx, RTCRayHit8* rh) {
  rtcIntersect8(valid, scene, ctx, rh);
}
inline void intersect(const int* valid, RTCScene scene, RTCIntersectContext* ctx, RTCRayHit16* rh) {
  rtcIntersect16(valid, scene, ctx, rh);
}

// The lanes of `active` as one Embree packet of W rays (lanes not active stay invalid).
template <int W, class RayHitW>
void trace_packet(RTCScene scene, const std::vector<unsigned>& mesh_of_geom, RoundContext& rc, const Ray* rays,
                  uint32_t active, SceneAccel::PacketLane* lanes) {
  alignas(64) int valid[W];
  alignas(64) RayHitW rh;
  for (int l = 0; l < W; ++l) {
    // Inactive lanes carry a copy of an active ray: Embree ignores them, but their
    // values stay finite.
    const bool on = active >> l & 1u;
    const Ray& r = rays[on ? l : __builtin_ctz(active)];
    valid[l] = on ? -1 : 0;
    rh.ray.org_x[l] = r.o.x; rh.ray.org_y[l] = r.o.y; rh.ray.org_z[l] = r.o.z;
    rh.ray.dir_x[l] = r.d.x; rh.ray.dir_y[l] = r.d.y; rh.ray.dir_z[l] = r.d.z;
    rh.ray.tnear[l] = on ? lanes[l].t_start : 0.0f;
    rh.ray.tfar[l] = r.tmax;
    rh.ray.time[l] = 0.0f;
    rh.ray.mask[l] = 0xFFFFFFFFu;
    rh.ray.id[l] = unsigned(l);
    rh.ray.flags[l] = 0;
    rh.hit.geomID[l] = kNoGeometry;
    rh.hit.instID[0][l] = kNoGeometry;
  }
  intersect(valid, scene, &rc.context, &rh);
  evaluate_queue(&rc, &rh);

  // Per lane, as at the end of round(): a surviving triangle ends the walk.
  for (int l = 0; l < W; ++l) {
    if (!(active >> l & 1u)) continue;
    SceneAccel::PacketLane& lane = lanes[l];
    const bool mesh_hit = rh.hit.geomID[l] != kNoGeometry;
    lane.more = rc.buffer[l].finish(mesh_hit, rh.ray.tfar[l]);
    lane.count = rc.buffer[l].count;
    lane.mesh = MeshHit();
    if (mesh_hit) {
      lane.mesh.valid = true;
      lane.mesh.t = rh.ray.tfar[l];
      lane.mesh.mesh = mesh_of_geom[rh.hit.geomID[l]];
      lane.mesh.prim = rh.hit.primID[l];
      lane.mesh.u = rh.hit.u[l];
      lane.mesh.v = rh.hit.v[l];
    }
  }
}

}  // namespace

void SceneAccel::round_packet(const Ray* rays, uint32_t active, PacketLane* lanes, float min_transmittance,
                              uint64_t* candidates, uint64_t* packet_rounds) const {
  if (!active) return;
  if (active >> kMaxPacket) throw Error("round_packet: at most " + std::to_string(kMaxPacket) + " rays");
  // The narrowest Embree packet holding every active lane.
  const int width = active < (1u << 4) ? 4 : (active < (1u << 8) ? 8 : 16);
  RoundContext rc;
  rc.init(data_, settings_.cull, width, active);
  // Coherent rays: Embree traverses the frustum of the packet (of each octant of
  // directions in it), far cheaper than ray by ray, and reports every Gaussian
  // with all the lanes of the frustum, which are evaluated anyway, 4 or 8 at once.
  rc.context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  // Whether the rays share their origin (camera rays): then its unit-space image
  // is computed once per Gaussian, not per lane (the same arithmetic either way).
  // And whether their directions lie in one octant (see gaussian_intersect).
  auto octant = [](Vec3 d) { return (d.x < 0.0f ? 1 : 0) | (d.y < 0.0f ? 2 : 0) | (d.z < 0.0f ? 4 : 0); };
  const Ray& first = rays[__builtin_ctz(active)];
  rc.shared_origin = true;
  rc.one_octant = true;
  rc.origin[0] = first.o.x, rc.origin[1] = first.o.y, rc.origin[2] = first.o.z;
  for (int l = 0; l < width; ++l) {
    if (!(active >> l & 1u)) continue;
    rc.shared_origin &= rays[l].o.x == first.o.x && rays[l].o.y == first.o.y && rays[l].o.z == first.o.z;
    rc.one_octant &= octant(rays[l].d) == octant(first.d);
    rc.t_start[l] = lanes[l].t_start;
    rc.id_start[l] = lanes[l].id_start;
    rc.buffer[l].reset(lanes[l].hits, settings_.k, lanes[l].T0, min_transmittance);
  }
  // Inactive lanes: a start nothing lies after, so a stray candidate is never kept.
  for (int l = 0; l < width; ++l)
    if (!(active >> l & 1u)) rc.t_start[l] = INFINITY;

  if (width == 4) trace_packet<4, RTCRayHit4>(impl_->scene, impl_->mesh_of_geom, rc, rays, active, lanes);
  else if (width == 8) trace_packet<8, RTCRayHit8>(impl_->scene, impl_->mesh_of_geom, rc, rays, active, lanes);
  else trace_packet<16, RTCRayHit16>(impl_->scene, impl_->mesh_of_geom, rc, rays, active, lanes);
  if (candidates) *candidates += rc.candidates;
  if (packet_rounds) ++*packet_rounds;
}

}  // namespace ptir
