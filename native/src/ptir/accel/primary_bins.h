// Screen-space bins of the Gaussians for the camera rays of one pinhole camera:
// the ordered walk of a camera ray without BVH traversal.
//
// Every Gaussian whose proxy box (the box the BVH holds: it bounds the region
// where the Gaussian can be accepted) projects into a tile of kTileSide x
// kTileSide pixels (padded by a pixel against rounding) is listed in that tile,
// sorted by a lower bound of t_peak along any ray from the camera centre (0.99
// times the distance to the box), with the box's padded film rectangle. A camera
// ray through the tile skips the candidates whose rectangle it misses (no trace
// data touched) and evaluates the others in that order with the traversal's own arithmetic (peak_t_d2,
// hit_alpha), keeps the accepted hits in a heap, and hands a hit to the visitor
// as soon as no later candidate can come before it. So walk() gives exactly the
// hits, order, alphas and end (mesh or stop) of SceneAccel::walk, bit for bit,
// and stops evaluating once the ray is opaque.
//
// The tiles cover the image plus a border for the pixel filter's reach; a ray
// that falls outside them, or that does not start at the camera centre, takes
// SceneAccel::walk. Bins are built per camera (the field is frozen during a
// render), in parallel, and only when their lists fit the memory budget.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "ptir/accel/scene_accel.h"
#include "ptir/scene/camera.h"

namespace ptir {

class PrimaryBins {
 public:
  static constexpr int kTileSide = 4;         // pixels
  static constexpr int kBorder = 4;           // pixels of tiles beyond the image on each side
  static constexpr float kPadPixels = 1.0f;   // projected boxes grow by this much (rounding)

  // nullptr when the lists would exceed budget_bytes or the field is empty.
  static std::unique_ptr<PrimaryBins> build(const SceneAccel& accel, const Camera& camera, size_t budget_bytes);

  // SceneAccel::walk for a camera ray of this camera (same contract, same results).
  template <class Visit>
  WalkEnd walk(const Ray& ray, Visit&& visit, bool stop_when_opaque = false) const;

  size_t bytes() const { return entries_.size() * sizeof(Entry) + offsets_.size() * sizeof(uint32_t); }
  size_t entries() const { return entries_.size(); }

 private:
  struct Entry {
    float t_lower;  // no accepted hit of this Gaussian on a camera ray lies before this
    uint32_t slot;  // index into SceneAccel::trace_data()
    float u0, v0, u1, v1;  // film rectangle of its proxy box (tile-grid pixels, padded)
  };
  PrimaryBins(const SceneAccel& accel, const Camera& camera);
  // Tile of the ray's film position (u, v in tile-grid pixels), or -1 (outside
  // the tiles, or not a camera ray).
  int tile_of(const Ray& ray, float* u, float* v) const;
  bool evaluate(const Ray& ray, const Entry& e, GaussianHit* hit) const;

  const SceneAccel& accel_;
  Camera camera_;
  Mat3 world_to_camera_;
  int tiles_x_ = 0, tiles_y_ = 0;
  std::vector<uint32_t> offsets_;  // tile t: entries_[offsets_[t], offsets_[t + 1])
  std::vector<Entry> entries_;

  friend struct PrimaryBinsBuilder;
};

namespace primary_bins_detail {
inline bool hit_less(const GaussianHit& a, const GaussianHit& b) { return a.t < b.t || (a.t == b.t && a.id < b.id); }
// Min-heap on (t, id) over a small vector.
void push(std::vector<GaussianHit>& heap, const GaussianHit& h);
GaussianHit pop(std::vector<GaussianHit>& heap);
}  // namespace primary_bins_detail

template <class Visit>
WalkEnd PrimaryBins::walk(const Ray& ray, Visit&& visit, bool stop_when_opaque) const {
  float u, v;
  const int tile = tile_of(ray, &u, &v);
  if (tile < 0) return accel_.walk(ray, visit, nullptr, stop_when_opaque);
  namespace d = primary_bins_detail;
  const float min_T = stop_when_opaque ? accel_.settings().cull.min_transmittance : 0.0f;
  WalkEnd end;
  // Hits lie in front of the first triangle (the walk ends there).
  MeshHit mesh = accel_.meshes().empty() ? MeshHit() : accel_.closest_mesh(ray);
  const float t_end = mesh.valid ? mesh.t : ray.tmax;
  thread_local std::vector<GaussianHit> heap;
  heap.clear();
  float T = 1.0f;
  auto hand_over = [&](const GaussianHit& h) {
    T *= 1.0f - h.alpha;
    return visit(h) && !(T < min_T);
  };
  for (uint32_t i = offsets_[size_t(tile)], e = offsets_[size_t(tile) + 1]; i < e; ++i) {
    const Entry& c = entries_[i];
    if (c.t_lower > t_end) break;
    // Hits before this candidate's bound are final: nothing later comes before them.
    while (!heap.empty() && heap.front().t < c.t_lower)
      if (!hand_over(d::pop(heap))) {
        end.stopped = true;
        return end;
      }
    if (u < c.u0 || u > c.u1 || v < c.v0 || v > c.v1) continue;
    GaussianHit h;
    if (evaluate(ray, c, &h) && (!mesh.valid || h.t < mesh.t)) d::push(heap, h);
  }
  while (!heap.empty())
    if (!hand_over(d::pop(heap))) {
      end.stopped = true;
      return end;
    }
  end.mesh = mesh;
  return end;
}

}  // namespace ptir
