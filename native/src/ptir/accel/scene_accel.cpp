#include "ptir/accel/scene_accel.h"

#include <embree3/rtcore.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <string>

#include "ptir/accel/round_context.h"
#include "ptir/core/error.h"

namespace ptir {

namespace {

constexpr unsigned kNoGeometry = RTC_INVALID_GEOMETRY_ID;

// An Embree ray (single) for `ray` starting at tnear, with no hit yet.
RTCRayHit embree_ray(const Ray& ray, float tnear) {
  RTCRayHit rh;
  rh.ray.org_x = ray.o.x; rh.ray.org_y = ray.o.y; rh.ray.org_z = ray.o.z;
  rh.ray.dir_x = ray.d.x; rh.ray.dir_y = ray.d.y; rh.ray.dir_z = ray.d.z;
  rh.ray.tnear = tnear;
  rh.ray.tfar = ray.tmax;
  rh.ray.time = 0.0f;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = kNoGeometry;
  rh.hit.instID[0] = kNoGeometry;
  return rh;
}

void gaussian_bounds(const RTCBoundsFunctionArguments* args) {
  const auto* boxes = static_cast<const std::vector<RTCBounds>*>(args->geometryUserPtr);
  *args->bounds_o = (*boxes)[args->primID];
}

const char* error_name(RTCError code) {
  switch (code) {
    case RTC_ERROR_NONE: return "no error";
    case RTC_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION: return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY: return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU: return "unsupported CPU";
    case RTC_ERROR_CANCELLED: return "cancelled";
    default: return "unknown error";
  }
}

// Keeps the first message Embree reports; the call sites that check
// rtcGetDeviceError turn it into the exception.
void embree_error(void* user, RTCError code, const char* message) {
  auto* log = static_cast<EmbreeErrorLog*>(user);
  std::lock_guard<std::mutex> lock(log->mutex);
  if (log->first.empty()) log->first = message && *message ? message : error_name(code);
}

void check_device(RTCDevice device, EmbreeErrorLog& log, const char* what) {
  RTCError err = rtcGetDeviceError(device);
  if (err == RTC_ERROR_NONE) return;
  std::lock_guard<std::mutex> lock(log.mutex);
  const std::string message = log.first.empty() ? error_name(err) : log.first;
  throw Error(std::string("Embree failed while ") + what + ": " + message + " (" + error_name(err) + ", code " +
              std::to_string(int(err)) + ")");
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

RTCBounds to_rtc(const ProxyBox& b) {
  RTCBounds r;
  r.lower_x = b.lo.x; r.lower_y = b.lo.y; r.lower_z = b.lo.z;
  r.upper_x = b.hi.x; r.upper_y = b.hi.y; r.upper_z = b.hi.z;
  r.align0 = r.align1 = 0.0f;
  return r;
}

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
  auto t0 = std::chrono::steady_clock::now();
  data_ = make_trace_data(field, settings_.cull);
  build_times_.trace_data = seconds_since(t0);
  // Up to 4 Gaussians per BVH leaf (Embree's SAH decides): fewer nodes to traverse
  // for a few more Gaussians to evaluate, which is cheaper (5-10% on the bench).
  // PTIR_EMBREE_CONFIG adds Embree device options, e.g. "verbose=2".
  std::string config = "object_accel_max_leaf_size=4";
  if (const char* extra = std::getenv("PTIR_EMBREE_CONFIG")) config += std::string(",") + extra;
  impl_->device = rtcNewDevice(config.c_str());
  if (!impl_->device) {
    const RTCError err = rtcGetDeviceError(nullptr);
    throw Error(std::string("Embree device could not be created with config '") + config + "': " + error_name(err) +
                " (code " + std::to_string(int(err)) + ")");
  }
  rtcSetDeviceErrorFunction(impl_->device, embree_error, &impl_->errors);
  impl_->scene = rtcNewScene(impl_->device);
  impl_->mesh_scene = rtcNewScene(impl_->device);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  rtcSetSceneBuildQuality(impl_->mesh_scene, RTC_BUILD_QUALITY_HIGH);

  // Geometry 0: the Gaussians as user primitives (primID = trace-data slot), each
  // bounded by the box of its accepted ellipsoid; an empty (inverted) box, which
  // Embree skips, when it can never be a hit.
  unsigned next_id = 0;
  if (field.size() > 0) {
    t0 = std::chrono::steady_clock::now();
    impl_->boxes.resize(data_.size());
    for (size_t slot = 0; slot < data_.size(); ++slot) impl_->boxes[slot] = to_rtc(proxy_box(field, data_[slot]));
    build_times_.boxes = seconds_since(t0);
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(geom, unsigned(data_.size()));
    rtcSetGeometryUserData(geom, &impl_->boxes);
    rtcSetGeometryBoundsFunction(geom, gaussian_bounds, nullptr);
    rtcSetGeometryIntersectFunction(geom, gaussian_intersect);
    rtcSetGeometryOccludedFunction(geom, gaussian_occluded);
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
  t0 = std::chrono::steady_clock::now();
  rtcCommitScene(impl_->scene);
  check_device(impl_->device, impl_->errors, "building the scene");
  rtcCommitScene(impl_->mesh_scene);
  check_device(impl_->device, impl_->errors, "building the mesh scene");
  build_times_.bvh = seconds_since(t0);
}

SceneAccel::~SceneAccel() = default;

int SceneAccel::round(const Ray& ray, float t_start, int64_t id_start, GaussianHit* buffer, MeshHit* mesh, bool* more,
                      uint64_t* candidates, float T0, float min_transmittance, const HitTest* skip) const {
  RoundContext rc;
  rc.init(data_, settings_.cull, 1, 1u);
  rc.skip = skip;
  rc.t_start[0] = t_start;
  rc.id_start[0] = id_start;
  KBuffer& kb = rc.buffer[0];
  kb.reset(buffer, settings_.k, T0, min_transmittance);

  RTCRayHit rh = embree_ray(ray, t_start);
  rtcIntersect1(impl_->scene, &rc.context, &rh);
  if (candidates) *candidates += rc.candidates;

  // A triangle hit survived: the walk ends there, after the Gaussians before it.
  const bool mesh_hit = rh.hit.geomID != kNoGeometry;
  *more = kb.finish(mesh_hit, rh.ray.tfar);
  mesh->valid = mesh_hit;
  if (mesh_hit) {
    mesh->t = rh.ray.tfar;
    mesh->mesh = impl_->mesh_of_geom[rh.hit.geomID];
    mesh->prim = rh.hit.primID;
    mesh->u = rh.hit.u;
    mesh->v = rh.hit.v;
  }
  return kb.count;
}

bool SceneAccel::occluded(const Ray& ray, const HitTest& occludes) const {
  OcclusionContext oc;
  rtcInitIntersectContext(&oc.context);
  oc.data = data_.data();
  oc.cull = settings_.cull;
  oc.t_min = ray.tmin;
  oc.occludes = &occludes;
  RTCRay r = embree_ray(ray, ray.tmin).ray;
  rtcOccluded1(impl_->scene, &oc.context, &r);
  // Embree sets tfar to -inf when it found an occluder (a triangle or a Gaussian above).
  return r.tfar == -INFINITY;
}

MeshHit SceneAccel::closest_mesh(const Ray& ray) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh = embree_ray(ray, ray.tmin);
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
