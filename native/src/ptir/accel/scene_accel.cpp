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
  CullSettings cull;
  float t_start;
  int64_t id_start;
  GaussianHit* buffer;
  int k;
  int count;
};

inline bool hit_before(float t, uint32_t id, const GaussianHit& h) { return t < h.t || (t == h.t && id < h.id); }

void gaussian_bounds(const RTCBoundsFunctionArguments* args) {
  const auto* table = static_cast<const BoxTable*>(args->geometryUserPtr);
  *args->bounds_o = table->boxes[args->primID];
}

// Intersect callback: evaluate the Gaussian's peak response and keep the hit in
// the round's sorted k-buffer. It never reports a hit to Embree; it only shrinks
// tfar once the buffer is full.
void gaussian_intersect(const RTCIntersectFunctionNArguments* args) {
  if (!args->valid[0]) return;
  auto* rc = reinterpret_cast<RoundContext*>(args->context);
  auto* rayhit = reinterpret_cast<RTCRayHit*>(args->rayhit);
  RTCRay& ray = rayhit->ray;
  const uint32_t id = args->primID;
  const GaussianTraceData& g = rc->data[id];

  // Peak along the ray: after the last processed hit, before tfar, not culled.
  Vec3 o(ray.org_x, ray.org_y, ray.org_z), d(ray.dir_x, ray.dir_y, ray.dir_z);
  PeakResponse p = peak_response(g, o, d);
  if (!(p.t >= rc->t_start) || (p.t == rc->t_start && int64_t(id) <= rc->id_start)) return;
  if (!(p.t <= ray.tfar)) return;
  float alpha = hit_alpha(p, g.opacity, rc->cull);
  if (alpha <= 0.0f) return;

  // Drop buffered hits that a triangle found since then hides.
  while (rc->count > 0 && rc->buffer[rc->count - 1].t > ray.tfar) rc->count--;
  if (rc->count == rc->k && !hit_before(p.t, id, rc->buffer[rc->k - 1])) return;

  // Insert into the sorted buffer (the last entry falls off when full).
  int i = std::min(rc->count, rc->k - 1);
  while (i > 0 && hit_before(p.t, id, rc->buffer[i - 1])) {
    rc->buffer[i] = rc->buffer[i - 1];
    --i;
  }
  rc->buffer[i] = GaussianHit{p.t, alpha, id};
  if (rc->count < rc->k) rc->count++;

  // A full buffer bounds the round: nothing behind its last hit matters now.
  if (rc->count == rc->k && rc->buffer[rc->k - 1].t < ray.tfar) {
    ray.tfar = rc->buffer[rc->k - 1].t;
    // A triangle found earlier lies behind the new tfar; a later round finds it again.
    rayhit->hit.geomID = kNoGeometry;
  }
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

std::vector<GaussianTraceData> make_trace_data(const GaussianField& field) {
  std::vector<GaussianTraceData> data(field.size());
  for (size_t i = 0; i < field.size(); ++i) {
    Mat3 r = field.rotation_matrix(i);
    Vec3 s = field.scale[i];
    float s_floor = std::max(kMinScale, kMinScaleRatio * max_component(s));
    s = vmax(s, Vec3(s_floor));
    // Rows of S^-1 R^T are the local axes divided by their scales.
    data[i].mu = field.position[i];
    data[i].opacity = field.opacity[i];
    data[i].to_unit = Mat3::from_rows(r.col(0) / s.x, r.col(1) / s.y, r.col(2) / s.z);
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
  data_ = make_trace_data(field);
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
    impl_->boxes.boxes.resize(field.size());
    for (size_t i = 0; i < field.size(); ++i) {
      float r2 = accept_radius_sq(field.opacity[i], settings_.cull);
      if (r2 < 0.0f) {
        // Never a hit: an empty box far from everything.
        RTCBounds b{};
        b.lower_x = b.lower_y = b.lower_z = 1.0f;
        b.upper_x = b.upper_y = b.upper_z = -1.0f;
        impl_->boxes.boxes[i] = b;
        continue;
      }
      impl_->boxes.boxes[i] = proxy_box(field, i, std::sqrt(r2) * kBoundPad);
    }
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(geom, unsigned(field.size()));
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

int SceneAccel::round(const Ray& ray, float t_start, int64_t id_start, GaussianHit* buffer, MeshHit* mesh, bool* more) const {
  RoundContext rc;
  rtcInitIntersectContext(&rc.context);
  rc.data = data_.data();
  rc.cull = settings_.cull;
  rc.t_start = t_start;
  rc.id_start = id_start;
  rc.buffer = buffer;
  rc.k = settings_.k;
  rc.count = 0;

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
  // Hits may remain only if the buffer filled up.
  *more = rc.count == rc.k;
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
