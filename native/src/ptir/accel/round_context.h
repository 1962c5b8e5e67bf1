// What the Embree intersect callback of the Gaussians sees during one traversal
// round, of one ray or of a packet of rays, and the Embree objects of a
// SceneAccel (internal to the traversal).
#pragma once

#include <embree3/rtcore.h>

#include <mutex>
#include <string>
#include <vector>

#include "ptir/accel/kbuffer.h"
#include "ptir/accel/scene_accel.h"

namespace ptir {

// Reached from the callback through the intersect context (which must stay the
// first member). Lane i of a packet is ray i of the RTCRayHitN given to Embree.
//
// For a packet, the callback only queues the Gaussians Embree reports; they are
// evaluated in batches (evaluate_queue) when the queue is full and when the
// traversal ends. A batch runs at the speed of the arithmetic, with its loads
// prefetched, where one Gaussian per callback would wait on each load and each
// dependent chain. The k-buffers end the same either way: their content does not
// depend on the order of the candidates, and tfar only prunes what they would
// reject. (A single ray is evaluated at once: there, pruning early pays more.)
struct RoundContext {
  static constexpr int kQueue = 64;  // Gaussians queued before a batch runs

  RTCIntersectContext context;
  const GaussianTraceData* data;
  CullSettings cull;
  const HitTest* skip;  // single rays: hits it returns true for are dropped (null: none)
  int lanes;            // 1: rtcIntersect1 (RTCRayHit); 4, 8, 16: rtcIntersectN
  uint32_t active;      // lanes traced this round (bit i: lane i)
  bool shared_origin;   // every active lane starts at `origin`
  bool one_octant;      // every active lane's direction has the same signs (as Embree tells them)
  float origin[3];
  uint64_t candidates;  // Gaussians tested, summed over lanes
  int queued;
  uint32_t queue[kQueue];       // trace-data slots
  uint32_t queue_lanes[kQueue];  // the lanes Embree reported each for (bit i: lane i)
  // Per lane: the round starts after (t_start, id_start) (id_start = -1 admits t == t_start).
  alignas(64) float t_start[SceneAccel::kMaxPacket];
  int64_t id_start[SceneAccel::kMaxPacket];
  KBuffer buffer[SceneAccel::kMaxPacket];

  void init(const std::vector<GaussianTraceData>& trace, const CullSettings& cull_, int lanes_, uint32_t active_) {
    rtcInitIntersectContext(&context);
    data = trace.data();
    cull = cull_;
    skip = nullptr;
    lanes = lanes_;
    active = active_;
    shared_origin = false;
    one_octant = false;
    candidates = 0;
    queued = 0;
  }
};

// The intersect function of the Gaussians' user geometry: evaluates the Gaussian
// against one ray, or queues it for a packet. It never reports a hit to Embree.
void gaussian_intersect(const RTCIntersectFunctionNArguments* args);

// What the occluded callback sees during SceneAccel::occluded (the intersect
// context must stay the first member).
struct OcclusionContext {
  RTCIntersectContext context;
  const GaussianTraceData* data;
  CullSettings cull;
  float t_min;             // accepted peaks lie in [t_min, tfar]
  const HitTest* occludes;
};

// The occluded function of the Gaussians' user geometry: reports the ray
// occluded (tfar = -inf, which ends Embree's traversal) when the Gaussian is an
// accepted hit that `occludes` accepts.
void gaussian_occluded(const RTCOccludedFunctionNArguments* args);

// Evaluates the queued Gaussians against the packet `rayhit`: fills the k-buffers
// and shrinks tfar. Call it once more after the traversal.
void evaluate_queue(RoundContext* rc, void* rayhit);

// The first message Embree's error callback reported (it may report from its
// build threads), for the exception of the call site that sees the error code.
struct EmbreeErrorLog {
  std::mutex mutex;
  std::string first;
};

// The Embree objects behind a SceneAccel.
struct SceneAccel::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  RTCScene mesh_scene = nullptr;       // triangles only, for closest_mesh
  std::vector<unsigned> mesh_of_geom;  // geomID -> mesh index (RTC_INVALID_GEOMETRY_ID for the Gaussians)
  std::vector<RTCBounds> boxes;        // proxy box per Gaussian (trace-data order)
  EmbreeErrorLog errors;               // what Embree's error callback reported

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (mesh_scene) rtcReleaseScene(mesh_scene);
    if (device) rtcReleaseDevice(device);
  }
};

}  // namespace ptir
