#include "ptir/accel/scene_accel.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "ptir/core/error.h"

namespace ptir {

namespace {

// Smallest scale relative to the largest one, so flat Gaussians keep a finite
// unit-space transform (their thickness stays far below any pixel).
constexpr float kMinScaleRatio = 1e-6f;
constexpr float kMinScale = 1e-12f;
// The proxy box is padded so hits exactly on the accepted boundary survive rounding.
constexpr float kBoundPad = 1.001f;

constexpr unsigned kNoGeometry = RTC_INVALID_GEOMETRY_ID;

// Geometry user data: per-Gaussian proxy boxes.
struct BoxTable {
  std::vector<RTCBounds> boxes;
};

// Per-round state, reached from the intersect callback through the context
// (RTCIntersectContext must stay the first member).
struct RoundContext {
  RTCIntersectContext context;
  const GaussianTraceData* data;
  uint32_t data_size;
  uint32_t cluster;  // Gaussians per Embree primitive
  CullSettings cull;
  float t_start;
  int64_t id_start;
  GaussianHit* buffer;
  int k;
  int count;
  uint64_t candidates;
  // Opacity-aware cut: T_after[i] = T0 * prod_{j<=i} (1 - alpha_j) over the buffer.
  float T0;
  float min_T;  // 0: no cut
  bool opaque;  // the buffer ends at the hit where T fell below min_T
  float T_after[SceneAccel::kMaxK];
};

inline bool hit_before(float t, uint32_t id, const GaussianHit& h) { return t < h.t || (t == h.t && id < h.id); }

void gaussian_bounds(const RTCBoundsFunctionArguments* args) {
  const auto* table = static_cast<const BoxTable*>(args->geometryUserPtr);
  *args->bounds_o = table->boxes[args->primID];
}

// Keeps one candidate hit in the round's sorted k-buffer; shrinks tfar once the
// buffer is full.
inline void consider(RoundContext* rc, RTCRayHit* rayhit, const GaussianTraceData& g, Vec3 o, Vec3 d) {
  RTCRay& ray = rayhit->ray;
  const uint32_t id = g.id;

  // Peak along the ray (unit space): after the last processed hit, before tfar.
  UnitRay u = to_unit_ray(g, o, d);
  float t = peak_t(u);
  if (!(t >= rc->t_start) || (t == rc->t_start && int64_t(id) <= rc->id_start)) return;
  if (!(t <= ray.tfar)) return;
  // Cull on the squared distance at the peak; exp only for accepted hits.
  float alpha = hit_alpha(peak_d2(u), g.opacity, g.accept_d2, rc->cull);
  if (alpha <= 0.0f) return;

  // Drop buffered hits that a triangle found since then hides (the opaque cut, being
  // the last entry, goes first).
  while (rc->count > 0 && rc->buffer[rc->count - 1].t > ray.tfar) {
    rc->count--;
    rc->opaque = false;
  }
  // Behind the last entry of a full or opaque buffer: never needed.
  if ((rc->count == rc->k || rc->opaque) && !hit_before(t, id, rc->buffer[rc->count - 1])) return;

  // Insert into the sorted buffer (the last entry falls off when full).
  int i = std::min(rc->count, rc->k - 1);
  while (i > 0 && hit_before(t, id, rc->buffer[i - 1])) {
    rc->buffer[i] = rc->buffer[i - 1];
    --i;
  }
  rc->buffer[i] = GaussianHit{t, alpha, id};
  if (rc->count < rc->k) rc->count++;

  // Opacity cut: once the buffered prefix is opaque, nothing behind it is visited.
  if (rc->min_T > 0.0f) {
    rc->opaque = false;  // entries before i are not opaque (else this hit would lie behind the cut)
    float T = i == 0 ? rc->T0 : rc->T_after[i - 1];
    for (int j = i; j < rc->count; ++j) {
      T *= 1.0f - rc->buffer[j].alpha;
      rc->T_after[j] = T;
      if (T < rc->min_T) {
        rc->count = j + 1;
        rc->opaque = true;
        break;
      }
    }
  }

  // A full (or opaque) buffer bounds the round: nothing behind its last hit matters now.
  if ((rc->count == rc->k || rc->opaque) && rc->buffer[rc->count - 1].t < ray.tfar) {
    ray.tfar = rc->buffer[rc->count - 1].t;
    // A triangle found earlier lies behind the new tfar; a later round finds it again.
    rayhit->hit.geomID = kNoGeometry;
  }
}

// Intersect callback of one Embree primitive: a cluster of Gaussians adjacent in
// memory (Morton order). It never reports a hit to Embree; it only fills the
// k-buffer and shrinks tfar.
void gaussian_intersect(const RTCIntersectFunctionNArguments* args) {
  if (!args->valid[0]) return;
  auto* rc = reinterpret_cast<RoundContext*>(args->context);
  auto* rayhit = reinterpret_cast<RTCRayHit*>(args->rayhit);
  const RTCRay& ray = rayhit->ray;
  Vec3 o(ray.org_x, ray.org_y, ray.org_z), d(ray.dir_x, ray.dir_y, ray.dir_z);
  uint32_t begin = args->primID * rc->cluster, end = std::min(begin + rc->cluster, rc->data_size);
  rc->candidates += end - begin;
  for (uint32_t slot = begin; slot < end; ++slot) consider(rc, rayhit, rc->data[slot], o, d);
}

void embree_error(void*, RTCError code, const char* message) {
  // Reported errors are turned into exceptions at the call sites that check rtcGetDeviceError.
  (void)code;
  (void)message;
}

RTCBounds proxy_box(const GaussianField& field, size_t i, float radius) {
  // Half extent along world axis j of the ellipsoid R diag(radius * s): radius * |row_j(R S)|.
  Mat3 r = field.rotation_matrix(i);
  Vec3 s = field.scale[i];
  Vec3 mu = field.position[i];
  RTCBounds b;
  float ext[3];
  for (int j = 0; j < 3; ++j) {
    Vec3 row = r.row(j) * s;
    ext[j] = radius * length(row);
  }
  b.lower_x = mu.x - ext[0]; b.upper_x = mu.x + ext[0];
  b.lower_y = mu.y - ext[1]; b.upper_y = mu.y + ext[1];
  b.lower_z = mu.z - ext[2]; b.upper_z = mu.z + ext[2];
  b.align0 = b.align1 = 0.0f;
  return b;
}

void check_device(RTCDevice device, const char* what) {
  RTCError err = rtcGetDeviceError(device);
  if (err != RTC_ERROR_NONE) throw Error(std::string("Embree failed while ") + what + " (error " + std::to_string(int(err)) + ")");
}

}  // namespace

namespace {

// Spreads the low 10 bits of v to every third bit (Morton code helper).
uint32_t spread_bits(uint32_t v) {
  v &= 0x3FF;
  v = (v | (v << 16)) & 0x030000FF;
  v = (v | (v << 8)) & 0x0300F00F;
  v = (v | (v << 4)) & 0x030C30C3;
  v = (v | (v << 2)) & 0x09249249;
  return v;
}

// Gaussian indices sorted along a Morton curve over the field's bounds, so that
// Gaussians close in space are close in memory: a ray's candidates then share
// cache lines (the traversal is bound by memory latency, not arithmetic).
std::vector<uint32_t> morton_order(const GaussianField& field) {
  Vec3 lo(INFINITY), hi(-INFINITY);
  for (const Vec3& p : field.position) {
    lo = vmin(lo, p);
    hi = vmax(hi, p);
  }
  Vec3 extent = vmax(hi - lo, Vec3(1e-20f));
  std::vector<std::pair<uint32_t, uint32_t>> keys(field.size());
  for (size_t i = 0; i < field.size(); ++i) {
    Vec3 q = (field.position[i] - lo) / extent * 1023.0f;
    uint32_t code = (spread_bits(uint32_t(q.x)) << 2) | (spread_bits(uint32_t(q.y)) << 1) | spread_bits(uint32_t(q.z));
    keys[i] = {code, uint32_t(i)};
  }
  std::sort(keys.begin(), keys.end());
  std::vector<uint32_t> order(field.size());
  for (size_t i = 0; i < keys.size(); ++i) order[i] = keys[i].second;
  return order;
}

}  // namespace

std::vector<GaussianTraceData> make_trace_data(const GaussianField& field, const CullSettings& cull) {
  std::vector<uint32_t> order = morton_order(field);
  std::vector<GaussianTraceData> data(field.size());
  for (size_t slot = 0; slot < field.size(); ++slot) {
    const uint32_t i = order[slot];
    Mat3 r = field.rotation_matrix(i);
    Vec3 s = field.scale[i];
    float s_floor = std::max(kMinScale, kMinScaleRatio * max_component(s));
    s = vmax(s, Vec3(s_floor));
    // Rows of S^-1 R^T are the local axes divided by their scales.
    GaussianTraceData& g = data[slot];
    g.mu = field.position[i];
    g.opacity = field.opacity[i];
    g.to_unit = Mat3::from_rows(r.col(0) / s.x, r.col(1) / s.y, r.col(2) / s.z);
    g.accept_d2 = accept_radius_sq(field.opacity[i], cull);
    g.id = i;
  }
  return data;
}

struct SceneAccel::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  RTCScene mesh_scene = nullptr;  // triangles only, for closest_mesh
  std::vector<unsigned> mesh_of_geom;  // geomID -> mesh index (kNoGeometry for the Gaussians)
  BoxTable boxes;

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (mesh_scene) rtcReleaseScene(mesh_scene);
    if (device) rtcReleaseDevice(device);
  }
};

namespace {

void attach_mesh(RTCDevice device, RTCScene scene, const TriangleMesh& mesh, unsigned geom_id) {
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  // Embree reads vertices with 16-byte loads: the buffer it allocates is padded.
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                        3 * sizeof(float), mesh.vertices.size()));
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    v[3 * i + 0] = mesh.vertices[i].x;
    v[3 * i + 1] = mesh.vertices[i].y;
    v[3 * i + 2] = mesh.vertices[i].z;
  }
  auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(unsigned), mesh.triangles.size()));
  for (size_t i = 0; i < mesh.triangles.size(); ++i)
    for (int c = 0; c < 3; ++c) idx[3 * i + c] = mesh.triangles[i][c];
  rtcCommitGeometry(geom);
  rtcAttachGeometryByID(scene, geom, geom_id);
  rtcReleaseGeometry(geom);
}

}  // namespace

SceneAccel::SceneAccel(const GaussianField& field, const std::vector<TriangleMesh>& meshes, const AccelSettings& settings)
    : impl_(std::make_unique<Impl>()), field_(&field), meshes_(&meshes), settings_(settings) {
  if (settings_.k < 1 || settings_.k > kMaxK) throw Error("k-buffer size must be in 1.." + std::to_string(kMaxK));
  if (settings_.cluster < 1 || settings_.cluster > 64) throw Error("Gaussians per BVH primitive must be in 1..64");
  data_ = make_trace_data(field, settings_.cull);
  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device) throw Error("Embree device could not be created (error " + std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
  rtcSetDeviceErrorFunction(impl_->device, embree_error, nullptr);
  impl_->scene = rtcNewScene(impl_->device);
  impl_->mesh_scene = rtcNewScene(impl_->device);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  rtcSetSceneBuildQuality(impl_->mesh_scene, RTC_BUILD_QUALITY_HIGH);

  // Geometry 0: the Gaussians as user primitives bounded by their accepted ellipsoid.
  unsigned next_id = 0;
  if (field.size() > 0) {
    // One box per cluster of consecutive (Morton-ordered) Gaussians: the union of
    // their accepted ellipsoids' boxes; empty when none can ever be hit.
    const size_t cluster = size_t(settings_.cluster);
    const size_t clusters = (field.size() + cluster - 1) / cluster;
    impl_->boxes.boxes.resize(clusters);
    for (size_t c = 0; c < clusters; ++c) {
      RTCBounds b{};
      b.lower_x = b.lower_y = b.lower_z = INFINITY;
      b.upper_x = b.upper_y = b.upper_z = -INFINITY;
      for (size_t slot = c * cluster; slot < std::min((c + 1) * cluster, field.size()); ++slot) {
        float r2 = data_[slot].accept_d2;
        if (r2 < 0.0f) continue;
        RTCBounds g = proxy_box(field, data_[slot].id, std::sqrt(r2) * kBoundPad);
        b.lower_x = std::min(b.lower_x, g.lower_x); b.upper_x = std::max(b.upper_x, g.upper_x);
        b.lower_y = std::min(b.lower_y, g.lower_y); b.upper_y = std::max(b.upper_y, g.upper_y);
        b.lower_z = std::min(b.lower_z, g.lower_z); b.upper_z = std::max(b.upper_z, g.upper_z);
      }
      if (b.lower_x > b.upper_x) {
        // Never a hit: an inverted box Embree skips.
        b.lower_x = b.lower_y = b.lower_z = 1.0f;
        b.upper_x = b.upper_y = b.upper_z = -1.0f;
      }
      impl_->boxes.boxes[c] = b;
    }
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(geom, unsigned(clusters));
    rtcSetGeometryUserData(geom, &impl_->boxes);
    rtcSetGeometryBoundsFunction(geom, gaussian_bounds, nullptr);
    rtcSetGeometryIntersectFunction(geom, gaussian_intersect);
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(impl_->scene, geom, next_id++);
    rtcReleaseGeometry(geom);
    impl_->mesh_of_geom.push_back(kNoGeometry);
  }
  // Then one triangle geometry per mesh, in both scenes under the same mesh index.
  for (size_t m = 0; m < meshes.size(); ++m) {
    if (meshes[m].triangles.empty()) continue;
    attach_mesh(impl_->device, impl_->scene, meshes[m], next_id);
    attach_mesh(impl_->device, impl_->mesh_scene, meshes[m], unsigned(m));
    impl_->mesh_of_geom.push_back(unsigned(m));
    next_id++;
  }
  rtcCommitScene(impl_->scene);
  check_device(impl_->device, "building the scene");
  rtcCommitScene(impl_->mesh_scene);
  check_device(impl_->device, "building the mesh scene");
}

SceneAccel::~SceneAccel() = default;

int SceneAccel::round(const Ray& ray, float t_start, int64_t id_start, GaussianHit* buffer, MeshHit* mesh, bool* more,
                      uint64_t* candidates, float T0, float min_transmittance) const {
  RoundContext rc;
  rtcInitIntersectContext(&rc.context);
  rc.data = data_.data();
  rc.cull = settings_.cull;
  rc.t_start = t_start;
  rc.id_start = id_start;
  rc.data_size = uint32_t(data_.size());
  rc.cluster = uint32_t(settings_.cluster);
  rc.buffer = buffer;
  rc.k = settings_.k;
  rc.count = 0;
  rc.candidates = 0;
  rc.T0 = T0;
  rc.min_T = min_transmittance;
  rc.opaque = false;

  RTCRayHit rh;
  rh.ray.org_x = ray.o.x; rh.ray.org_y = ray.o.y; rh.ray.org_z = ray.o.z;
  rh.ray.dir_x = ray.d.x; rh.ray.dir_y = ray.d.y; rh.ray.dir_z = ray.d.z;
  rh.ray.tnear = t_start;
  rh.ray.tfar = ray.tmax;
  rh.ray.time = 0.0f;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = kNoGeometry;
  rh.hit.instID[0] = kNoGeometry;
  rtcIntersect1(impl_->scene, &rc.context, &rh);
  if (candidates) *candidates += rc.candidates;

  // A triangle hit survived: the walk ends there, after the Gaussians before it.
  if (rh.hit.geomID != kNoGeometry) {
    while (rc.count > 0 && rc.buffer[rc.count - 1].t >= rh.ray.tfar) rc.count--;
    mesh->valid = true;
    mesh->t = rh.ray.tfar;
    mesh->mesh = impl_->mesh_of_geom[rh.hit.geomID];
    mesh->prim = rh.hit.primID;
    mesh->u = rh.hit.u;
    mesh->v = rh.hit.v;
    *more = false;
    return rc.count;
  }
  mesh->valid = false;
  // Hits may remain only if the buffer filled up before the ray became opaque.
  *more = rc.count == rc.k && !rc.opaque;
  return rc.count;
}

MeshHit SceneAccel::closest_mesh(const Ray& ray) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  rh.ray.org_x = ray.o.x; rh.ray.org_y = ray.o.y; rh.ray.org_z = ray.o.z;
  rh.ray.dir_x = ray.d.x; rh.ray.dir_y = ray.d.y; rh.ray.dir_z = ray.d.z;
  rh.ray.tnear = ray.tmin;
  rh.ray.tfar = ray.tmax;
  rh.ray.time = 0.0f;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = kNoGeometry;
  rh.hit.instID[0] = kNoGeometry;
  rtcIntersect1(impl_->mesh_scene, &ctx, &rh);
  MeshHit hit;
  if (rh.hit.geomID == kNoGeometry) return hit;
  hit.valid = true;
  hit.t = rh.ray.tfar;
  hit.mesh = rh.hit.geomID;
  hit.prim = rh.hit.primID;
  hit.u = rh.hit.u;
  hit.v = rh.hit.v;
  return hit;
}

}  // namespace ptir
