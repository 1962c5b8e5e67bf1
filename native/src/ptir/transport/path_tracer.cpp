#include "ptir/transport/path_tracer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "ptir/material/bsdf.h"
#include "ptir/math/path_sampler.h"
#include "ptir/math/rng.h"
#include "ptir/math/sampling.h"
#include "ptir/transport/field_radiance.h"
#include "ptir/transport/gradient_tile.h"
#include "ptir/transport/interaction.h"
#include "ptir/transport/path_record.h"
#include "ptir/transport/scattering.h"

namespace ptir {

PathTracer::PathTracer(const Scene& scene, const AccelSettings& accel_settings) : scene_(scene) {
  accel_ = std::make_unique<SceneAccel>(*scene.gaussians, scene.meshes, accel_settings);
  // Rays leave meshes 1e-5 of the scene's extent above the surface (floats carry ~1e-7).
  float extent = 0.0f;
  for (const TriangleMesh& m : scene.meshes)
    for (const Vec3& v : m.vertices) extent = std::max(extent, max_component(vabs(v)));
  for (const Vec3& p : scene.gaussians->position) extent = std::max(extent, max_component(vabs(p)));
  mesh_epsilon_ = 1e-5f * std::max(1.0f, extent);
  field_radiance_ = field_radiance(*scene.gaussians);
}

namespace {

// Emission of every light surface the ray crosses before max_t (area lights,
// finite point lights, suns with an angle; none are in the Embree scene and, as in
// Cycles, rays pass through them), MIS-weighted against the light sampling that
// next-event estimation did at the previous vertex (weight 1 for camera rays, which
// see only lights visible to the camera); `pick`: the probability that next-event
// estimation samples a given light.
Vec3 lights_crossed(const Scene& scene, const Ray& ray, float max_t, float prev_brdf_pdf, float pick) {
  Vec3 sum(0.0f);
  const bool camera_ray = !(prev_brdf_pdf > 0.0f);
  for (size_t i = 0; i < scene.emitters.size(); ++i) {
    if (camera_ray && !scene.emitter_visible_to_camera(i)) continue;
    LightHit h;
    Ray r = ray;
    r.tmax = max_t;
    if (!light_hit(scene.emitters[i], r, &h) || !(h.t < max_t)) continue;
    float w = camera_ray ? 1.0f : power_heuristic(1, prev_brdf_pdf, 1, pick * h.pdf);
    sum += h.Le * w;
  }
  return sum;
}

// Hands the adjoint of a vertex's BRDF parameters to what defined them: the
// Gaussians composited into the interaction (normalised weights w_i / O, or the
// picked one in discrete mode), or the mesh's material.
void scatter_vertex_adjoint(const NextEvent& ev, const std::vector<WeightedHit>& hits, const MaterialGrad& g,
                            InteractionMode mode, GradientTile& grads) {
  if (ev.kind == NextEvent::Mesh) {
    grads.add_mesh(uint32_t(ev.mesh.mesh), g.d_albedo, g.d_roughness, g.d_metallic);
    return;
  }
  if (mode == InteractionMode::Discrete) {
    grads.add_gaussian(uint32_t(ev.si.picked), g.d_albedo, g.d_roughness, g.d_metallic);
    return;
  }
  const float inv_O = 1.0f / ev.si.opacity;
  for (const WeightedHit& h : hits) {
    float w = h.weight * inv_O;
    grads.add_gaussian(uint32_t(h.id), w * g.d_albedo, w * g.d_roughness, w * g.d_metallic);
  }
}


// A path between its vertices, in either mode: the primal accumulates L; the
// replay starts L_rem at the primal L and takes every contribution off it as it
// is passed, so what is left is what later vertices bring.
struct PathState {
  const PathAdjoint* adj;  // null: primal
  Vec3 L, L_rem, beta;
  Ray ray;
  SpawnContext spawn;          // where `ray` left (the camera ray leaves no surface)
  float prev_brdf_pdf = 0.0f;  // density of the BRDF sample that produced `ray` (0: camera ray)

  PathState(const PathAdjoint* adjoint, const Ray& camera_ray)
      : adj(adjoint), L(0.0f), L_rem(adjoint ? adjoint->L : Vec3(0.0f)), beta(1.0f), ray(camera_ray) {}
  void add(Vec3 contribution) {
    if (adj) L_rem -= contribution;
    else L += contribution;
  }
};

// The escape of `ray`: the environment along it, MIS-weighted against next-event
// estimation's sampling of that direction (weight 1 for a camera ray); the replay
// hands its adjoint to the environment parameters looked up.
void add_escape(const Scene& scene, const Scatterer& scatterer, PathState& path) {
  // Radiance along d (black without an environment) and the density with which
  // next-event estimation samples d, from one lookup.
  float env_pdf = 0.0f;
  const Vec3 Le = path.prev_brdf_pdf > 0.0f ? scene.environment.eval_pdf(path.ray.d, &env_pdf)
                                            : scene.environment.eval(path.ray.d);
  float w = path.prev_brdf_pdf > 0.0f
                ? power_heuristic(1, path.prev_brdf_pdf, 1, scatterer.light_pick_probability() * env_pdf)
                : 1.0f;
  path.add(path.beta * Le * w);
  if (path.adj && path.adj->grads) path.adj->grads->add_environment(path.ray.d, path.adj->dL * path.beta * w);
}

// The ends of a path that need no walk (true: the path ends here, its escape
// added when it escaped). A replay that knows the ray escaped needs its direction
// alone; past the last vertex, whatever it meets otherwise only takes radiance off
// L_rem, which nothing reads afterwards. And the last ray (past the last vertex)
// brings only what it escapes to and the lights it crosses: when none lies along
// it and no mesh emits, whether it escapes is all that is asked (an occlusion
// query, not a walk).
bool ends_without_walk(const Scene& scene, const Scatterer& scatterer, PathRecord& record,
                       const IntegratorSettings& settings, uint64_t path_key, int bounce, PathState& path) {
  bool escaped;
  if (record.recall_escape(&escaped)) {
    if (escaped) {
      add_escape(scene, scatterer, path);
      return true;
    }
    if (bounce > settings.max_bounces) return true;
  }
  if (bounce > settings.max_bounces && scatterer.escape_query_applies() &&
      max_component(lights_crossed(scene, path.ray, INFINITY, path.prev_brdf_pdf,
                                   scatterer.light_pick_probability())) <= 0.0f) {
    escaped = scatterer.escapes(path.ray, path.spawn, path_key, uint32_t(bounce));
    record.record_escape(escaped);
    if (escaped) add_escape(scene, scatterer, path);
    return true;
  }
  return false;
}

// The BSDF of a vertex in its local frame, for the surface model the scene asks for.
Bsdf vertex_bsdf(const NextEvent& ev, const Frame& frame, Vec3 wo, const IntegratorSettings& settings) {
  Bsdf bsdf(resolve_bsdf(settings.brdf, ev.shader), ev.material, wo, settings.min_specular_probability);
  // A mesh's closure normal other than its own (a normal map, the reflection correction):
  // Cycles' bump shadowing of the diffuse lobe, which under Principled v2 keeps the
  // normal before the correction.
  if (ev.kind == NextEvent::Mesh) {
    const auto same = [](Vec3 a, Vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; };
    if (!same(ev.nm, ev.n))
      bsdf.set_bump_shadowing(frame.to_local(ev.ns), frame.to_local(ev.nm));
    else if (!same(ev.ns, ev.n))
      bsdf.set_bump_shadowing(frame.to_local(ev.ns));
  }
  return bsdf;
}

// Shades a vertex: next-event estimation, then the BSDF sample that continues the
// path (the replay hands the vertex's material adjoint to the Gaussians or the mesh
// that defined it). False: the path ends here.
bool shade_vertex(const Scatterer& scatterer, PathRecord& record, const NextEvent& ev,
                  const IntegratorSettings& settings, uint64_t path_key, int bounce, PathStats* stats,
                  PathState& path) {
  const PathAdjoint* adj = path.adj;
  if (stats) stats->vertices++;
  Frame frame(ev.n);
  Vec3 wo = frame.to_local(-path.ray.d);
  const Bsdf bsdf = vertex_bsdf(ev, frame, wo, settings);
  SpawnContext here = scatterer.spawn_context(ev, path.ray);
  MaterialGrad vertex_grad;

  // Next-event estimation: one sample of every light and of the environment.
  DirectAdjoint direct_adj{path.beta, adj ? adj->dL : Vec3(0.0f), &vertex_grad, adj ? adj->grads : nullptr};
  path.add(path.beta * scatterer.direct_light(here, frame, bsdf, path_key, uint32_t(bounce), stats,
                                              adj ? &direct_adj : nullptr, record.shadows(), record.light_samples()));

  // Continue with a BSDF sample.
  const BsdfSample bs = record.bsdf_sample(bsdf, path_key, bounce, frame, ev.kind == NextEvent::Mesh ? &ev.ng : nullptr);
  if (adj && bs.valid) {
    // Everything still remaining arrives through this BRDF value:
    // d L_rem / d f~ = L_rem / f~ (the L f / detach(f) trick), channel by channel.
    Vec3 f = bs.weight * bs.pdf;
    Vec3 d_f;
    for (int c = 0; c < 3; ++c) d_f[c] = f[c] > 0.0f ? adj->dL[c] * path.L_rem[c] / f[c] : 0.0f;
    bsdf.eval_grad(bs.wi, d_f, vertex_grad);
  }
  if (adj && adj->grads) scatter_vertex_adjoint(ev, record.hits(), vertex_grad, settings.interaction.mode, *adj->grads);
  if (!bs.valid) return false;
  path.beta *= bs.weight;
  if (max_component(path.beta) < settings.min_throughput) return false;
  path.prev_brdf_pdf = bs.pdf;
  path.ray = scatterer.spawn_ray(here, frame.to_world(bs.wi));
  path.spawn = here;
  return true;
}

}  // namespace

Vec3 PathTracer::sample_radiance(const Ray& camera_ray, uint64_t pixel, uint32_t sample, const IntegratorSettings& settings,
                                 float* coverage, PathStats* stats, uint64_t* shadow_bits) const {
  TraceIO io;
  io.coverage = coverage;
  io.stats = stats;
  io.record.shadow_bits = shadow_bits;
  return trace(camera_ray, pixel, sample, settings, nullptr, io);
}

void PathTracer::sample_adjoint(const Ray& camera_ray, uint64_t pixel, uint32_t sample, const IntegratorSettings& settings,
                                const PathAdjoint& adjoint) const {
  trace(camera_ray, pixel, sample, settings, &adjoint, TraceIO{});
}

void PathTracer::sample_radiance_batch(const Ray* camera_rays, int n, const uint64_t* pixels, const uint32_t* samples,
                                       const IntegratorSettings& settings, Vec3* L, float* coverage, PathStats* stats,
                                       uint64_t* shadow_bits, PathWalkWriter* walks) const {
  constexpr int P = SceneAccel::kMaxPacket;
  Scatterer scatterer(scene_, *accel_, settings, mesh_epsilon_, radiance());
  thread_local WalkCapture captures[P];
  for (int first = 0; first < n; first += P) {
    const int m = std::min(P, n - first);
    const auto io = [&](int i) {
      TraceIO t;
      t.coverage = coverage ? &coverage[i] : nullptr;
      t.stats = stats;
      t.record.shadow_bits = shadow_bits ? &shadow_bits[i] : nullptr;
      t.record.walks = walks ? &walks[i] : nullptr;
      return t;
    };
    if (m == 1) {  // nothing to trace together
      L[first] = trace(camera_rays[first], pixels[first], samples[first], settings, nullptr, io(first));
      continue;
    }
    uint64_t keys[P];
    NextEvent events[P];
    for (int l = 0; l < m; ++l) keys[l] = make_path_key(settings.seed, pixels[first + l], samples[first + l]);
    scatterer.camera_events(camera_rays + first, m, keys, events, nullptr, walks ? captures : nullptr);
    for (int l = 0; l < m; ++l) {
      const int i = first + l;
      TraceIO t = io(i);
      t.record.first = &events[l];
      t.record.first_walk = walks ? &captures[l] : nullptr;
      L[i] = trace(camera_rays[i], pixels[i], samples[i], settings, nullptr, t);
    }
  }
}

void PathTracer::sample_adjoint_batch(const Ray* camera_rays, int n, const uint64_t* pixels, const uint32_t* samples,
                                      const IntegratorSettings& settings, const PathAdjoint* adjoints) const {
  constexpr int P = SceneAccel::kMaxPacket;
  Scatterer scatterer(scene_, *accel_, settings, mesh_epsilon_, radiance());
  thread_local std::vector<WeightedHit> records[P];
  for (int first = 0; first < n; first += P) {
    const int m = std::min(P, n - first);
    // The lanes whose camera ray must be walked: not those the primal's record
    // says escaped (trace's first recall), nor those whose walks it kept (trace
    // reads them).
    int lane_of[P], walked = 0;
    Ray rays[P];
    uint64_t keys[P];
    for (int l = 0; l < m; ++l) {
      const PathAdjoint& a = adjoints[first + l];
      lane_of[l] = -1;
      if ((a.shadow_bits && (*a.shadow_bits & 1u)) || a.walks.recorded()) continue;
      lane_of[l] = walked;
      rays[walked] = camera_rays[first + l];
      keys[walked++] = make_path_key(settings.seed, pixels[first + l], samples[first + l]);
    }
    NextEvent events[P];
    if (walked > 1) {
      for (int w = 0; w < walked; ++w) records[w].clear();
      scatterer.camera_events(rays, walked, keys, events, records);
    }
    for (int l = 0; l < m; ++l) {
      const int i = first + l, w = walked > 1 ? lane_of[l] : -1;
      TraceIO t;
      if (w >= 0) {
        t.record.first = &events[w];
        t.record.first_hits = &records[w];
      }
      trace(camera_rays[i], pixels[i], samples[i], settings, &adjoints[i], t);
    }
  }
}

// The transport equation along one path (docs/method.md §4): at each vertex the
// emission met on the way, next-event estimation and a BSDF sample; the replay
// walks the same path and hands out the adjoints (§6).
Vec3 PathTracer::trace(const Ray& camera_ray, uint64_t pixel, uint32_t sample, const IntegratorSettings& settings,
                       const PathAdjoint* adj, const TraceIO& io) const {
  const Scene& scene = scene_;
  const uint64_t path_key = make_path_key(settings.seed, pixel, sample);  // stratified over the pixel's samples
  Scatterer scatterer(scene_, *accel_, settings, mesh_epsilon_, radiance());
  // What the replay reuses from the primal: recorded there, read back here (path_record.h).
  PathRecord record(adj, io.record);
  PathState path(adj, camera_ray);
  if (io.coverage) *io.coverage = 0.0f;
  if (io.stats) io.stats->paths++;

  for (int bounce = 0;; ++bounce) {
    if (ends_without_walk(scene, scatterer, record, settings, path_key, bounce, path)) break;
    // Next event along the ray: a Gaussian interaction, a mesh, or an escape.
    const NextEvent ev = record.next_event(scatterer, path.ray, path.spawn, path_key, bounce, bounce <= settings.max_bounces);
    if (bounce == 0 && io.coverage)
      *io.coverage = (ev.kind == NextEvent::Gaussian || ev.kind == NextEvent::Mesh) ? 1.0f : 0.0f;

    // Lights the ray crosses before the event (it goes on through them).
    path.add(path.beta * lights_crossed(scene, path.ray, ev.t, path.prev_brdf_pdf, scatterer.light_pick_probability()));
    if (ev.kind == NextEvent::Absorbed) break;
    if (ev.kind == NextEvent::Escape) {
      add_escape(scene, scatterer, path);
      break;
    }
    // Indirect light from the captured radiance: a ray leaving a vertex that meets
    // the splats ends with what they carry (IntegratorSettings::indirect_from_field).
    // No parameter defines it; its share reaches the previous vertex's BSDF through
    // L_rem like any later radiance.
    if (ev.kind == NextEvent::Gaussian && bounce > 0 && settings.indirect_from_field && radiance()) {
      path.add(path.beta * ev.si.radiance);
      break;
    }
    // Emissive meshes are reached by BRDF sampling only (no MIS partner).
    if (ev.kind == NextEvent::Mesh) path.add(path.beta * ev.emission);
    if (bounce > settings.max_bounces) break;
    // Russian roulette (Cycles' rule): past the first min_light_bounces vertices the
    // path goes on with probability q = min(sqrt(max beta), 1), carrying beta / q.
    if (settings.russian_roulette && bounce > settings.min_light_bounces) {
      const float q = std::min(std::sqrt(max_component(path.beta)), 1.0f);
      if (q < 1.0f) {
        if (!(PathRng(path_key, uint64_t(bounce), kStreamRoulette).at(0) < q)) break;
        path.beta *= 1.0f / q;
      }
    }
    if (!shade_vertex(scatterer, record, ev, settings, path_key, bounce, io.stats, path)) break;
  }
  record.finish();
  return path.L;
}

}  // namespace ptir
