#include "ptir/accel/primary_bins.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>

#include "ptir/accel/trace_data.h"

namespace ptir {

namespace primary_bins_detail {

void push(std::vector<GaussianHit>& heap, const GaussianHit& h) {
  heap.push_back(h);
  std::push_heap(heap.begin(), heap.end(), [](const GaussianHit& a, const GaussianHit& b) { return hit_less(b, a); });
}

GaussianHit pop(std::vector<GaussianHit>& heap) {
  std::pop_heap(heap.begin(), heap.end(), [](const GaussianHit& a, const GaussianHit& b) { return hit_less(b, a); });
  GaussianHit h = heap.back();
  heap.pop_back();
  return h;
}

}  // namespace primary_bins_detail

namespace {

constexpr float kLowerBoundScale = 0.99f;  // t_peak in float may fall a little short of the box distance
constexpr float kNearDepth = 1e-6f;

Mat3 inverse(const Mat3& a) {
  const Vec3 c0 = a.col(0), c1 = a.col(1), c2 = a.col(2);
  const Vec3 r0 = cross(c1, c2), r1 = cross(c2, c0), r2 = cross(c0, c1);
  const float inv_det = 1.0f / dot(c0, r0);
  return Mat3::from_rows(r0 * inv_det, r1 * inv_det, r2 * inv_det);
}

float distance_to_box(Vec3 p, const ProxyBox& b) {
  Vec3 d = vmax(vmax(b.lo - p, p - b.hi), Vec3(0.0f));
  return length(d);
}

// Tile rectangle [x0, x1) x [y0, y1) of one Gaussian (empty: x0 >= x1).
struct Footprint {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  float t_lower = 0.0f;
  float u0 = -INFINITY, v0 = -INFINITY, u1 = INFINITY, v1 = INFINITY;  // padded film rectangle
};

}  // namespace

PrimaryBins::PrimaryBins(const SceneAccel& accel, const Camera& camera)
    : accel_(accel), camera_(camera), world_to_camera_(inverse(camera.cam_to_world.linear)) {
  tiles_x_ = (camera.width + 2 * kBorder + kTileSide - 1) / kTileSide;
  tiles_y_ = (camera.height + 2 * kBorder + kTileSide - 1) / kTileSide;
}

int PrimaryBins::tile_of(const Ray& ray, float* pu, float* pv) const {
  const Vec3 c = camera_.centre();
  if (ray.o.x != c.x || ray.o.y != c.y || ray.o.z != c.z) return -1;
  const Vec3 q = world_to_camera_ * ray.d;
  if (!(q.z < 0.0f)) return -1;
  const float u = camera_.cx + camera_.fx * (q.x / -q.z) - float(camera_.crop_x) + float(kBorder);
  const float v = camera_.cy - camera_.fy * (q.y / -q.z) - float(camera_.crop_y) + float(kBorder);
  if (!(u >= 0.0f && v >= 0.0f)) return -1;
  *pu = u, *pv = v;
  const int tx = int(u) / kTileSide, ty = int(v) / kTileSide;
  if (!(u < float(tiles_x_ * kTileSide)) || !(v < float(tiles_y_ * kTileSide)) || tx >= tiles_x_ || ty >= tiles_y_) return -1;
  return ty * tiles_x_ + tx;
}

bool PrimaryBins::evaluate(const Ray& ray, const Entry& e, GaussianHit* hit) const {
  // The traversal's own test (gaussian_intersect.cpp, intersect_one) for a first round.
  const GaussianTraceData& g = accel_.trace_data()[e.slot];
  float t, d2;
  peak_t_d2(g, ray.o.x, ray.o.y, ray.o.z, ray.d.x, ray.d.y, ray.d.z, t, d2);
  if (!(t >= ray.tmin) || !(t <= ray.tmax)) return false;
  const float alpha = hit_alpha(d2, g.opacity, g.accept_d2, accel_.settings().cull);
  if (!(alpha > 0.0f)) return false;
  *hit = GaussianHit{t, alpha, g.id};
  return true;
}

std::unique_ptr<PrimaryBins> PrimaryBins::build(const SceneAccel& accel, const Camera& camera, size_t budget_bytes) {
  const auto& data = accel.trace_data();
  if (data.empty() || camera.width <= 0 || camera.height <= 0) return nullptr;
  std::unique_ptr<PrimaryBins> bins(new PrimaryBins(accel, camera));
  PrimaryBins& b = *bins;
  const size_t tiles = size_t(b.tiles_x_) * size_t(b.tiles_y_);
  const Vec3 centre = camera.centre();
  const Mat3& w2c = b.world_to_camera_;
  const float ox = float(kBorder) - float(camera.crop_x), oy = float(kBorder) - float(camera.crop_y);

  // Each Gaussian's tile rectangle and lower bound of t.
  std::vector<Footprint> foot(data.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, data.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t s = r.begin(); s < r.end(); ++s) {
      const ProxyBox box = proxy_box(accel.field(), data[s]);
      Footprint& f = foot[s];
      if (box.empty()) continue;
      float zmin = INFINITY, zmax = -INFINITY, umin = INFINITY, umax = -INFINITY, vmin_ = INFINITY, vmax_ = -INFINITY;
      for (int k = 0; k < 8; ++k) {
        Vec3 p((k & 1) ? box.hi.x : box.lo.x, (k & 2) ? box.hi.y : box.lo.y, (k & 4) ? box.hi.z : box.lo.z);
        Vec3 q = w2c * (p - centre);
        zmin = std::min(zmin, q.z), zmax = std::max(zmax, q.z);
        float u = camera.cx + camera.fx * (q.x / -q.z) + ox, v = camera.cy - camera.fy * (q.y / -q.z) + oy;
        umin = std::min(umin, u), umax = std::max(umax, u), vmin_ = std::min(vmin_, v), vmax_ = std::max(vmax_, v);
      }
      if (!(zmin < 0.0f)) continue;  // wholly behind the camera: no camera ray reaches it
      f.t_lower = kLowerBoundScale * distance_to_box(centre, box);
      if (!(zmax < -kNearDepth)) {  // straddles the camera plane: every tile
        f.x1 = b.tiles_x_, f.y1 = b.tiles_y_;
        continue;
      }
      auto tile = [](float p, int n) { return int(std::clamp(std::floor(p / float(kTileSide)), -1.0f, float(n))); };
      f.u0 = umin - kPadPixels, f.v0 = vmin_ - kPadPixels, f.u1 = umax + kPadPixels, f.v1 = vmax_ + kPadPixels;
      f.x0 = std::max(0, tile(umin - kPadPixels, b.tiles_x_));
      f.y0 = std::max(0, tile(vmin_ - kPadPixels, b.tiles_y_));
      f.x1 = std::min(b.tiles_x_, tile(umax + kPadPixels, b.tiles_x_) + 1);
      f.y1 = std::min(b.tiles_y_, tile(vmax_ + kPadPixels, b.tiles_y_) + 1);
      if (f.x0 >= f.x1 || f.y0 >= f.y1) f = Footprint();
    }
  });

  // Counts, the budget, then the lists (filled in parallel, sorted per tile: deterministic).
  std::vector<std::atomic<uint32_t>> count(tiles);
  for (auto& c : count) c.store(0, std::memory_order_relaxed);
  size_t total = 0;
  for (const Footprint& f : foot) total += size_t(std::max(0, f.x1 - f.x0)) * size_t(std::max(0, f.y1 - f.y0));
  if (total >= (size_t(1) << 32) || total * sizeof(Entry) + (tiles + 1) * sizeof(uint32_t) > budget_bytes) return nullptr;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, data.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t s = r.begin(); s < r.end(); ++s)
      for (int y = foot[s].y0; y < foot[s].y1; ++y)
        for (int x = foot[s].x0; x < foot[s].x1; ++x) count[size_t(y) * b.tiles_x_ + x].fetch_add(1, std::memory_order_relaxed);
  });
  b.offsets_.assign(tiles + 1, 0u);
  for (size_t t = 0; t < tiles; ++t) b.offsets_[t + 1] = b.offsets_[t] + count[t].load(std::memory_order_relaxed);
  for (size_t t = 0; t < tiles; ++t) count[t].store(b.offsets_[t], std::memory_order_relaxed);
  b.entries_.resize(total);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, data.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t s = r.begin(); s < r.end(); ++s)
      for (int y = foot[s].y0; y < foot[s].y1; ++y)
        for (int x = foot[s].x0; x < foot[s].x1; ++x) {
          uint32_t at = count[size_t(y) * b.tiles_x_ + x].fetch_add(1, std::memory_order_relaxed);
          const Footprint& f = foot[s];
          b.entries_[at] = Entry{f.t_lower, uint32_t(s), f.u0, f.v0, f.u1, f.v1};
        }
  });
  tbb::parallel_for(size_t(0), tiles, [&](size_t t) {
    std::sort(b.entries_.begin() + b.offsets_[t], b.entries_.begin() + b.offsets_[t + 1], [](const Entry& a, const Entry& c) {
      return a.t_lower < c.t_lower || (a.t_lower == c.t_lower && a.slot < c.slot);
    });
  });
  return bins;
}

}  // namespace ptir
