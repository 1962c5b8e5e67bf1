#include "ptir/transport/path_tracer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "ptir/material/disney_brdf.h"
#include "ptir/math/rng.h"
#include "ptir/math/sampling.h"
#include "ptir/transport/interaction.h"
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
}

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Radiance of the environment seen along d (black when the scene has none).
Vec3 environment_radiance(const SceneEnvironment& env, Vec3 d) {
  if (env.latlong) return env.latlong->eval(d);
  if (env.sg) return env.sg->eval(d);
  return Vec3(0.0f);
}

// Solid-angle density with which next-event estimation samples d from the environment.
float environment_pdf(const SceneEnvironment& env, Vec3 d) {
  if (env.latlong) return env.latlong->pdf(d);
  if (env.sg) return env.sg->pdf(d);
  return 0.0f;
}

// The closest light surface a ray meets before max_t (area lights, finite point
// lights, suns with an angle; none are in the Embree scene).
bool closest_light_hit(const std::vector<Emitter>& emitters, const Ray& ray, float max_t, LightHit* hit) {
  bool found = false;
  for (const Emitter& e : emitters) {
    LightHit h;
    Ray r = ray;
    r.tmax = max_t;
    if (light_hit(e, r, &h) && h.t < max_t && (!found || h.t < hit->t)) {
      *hit = h;
      found = true;
    }
  }
  return found;
}

}  // namespace

Vec3 PathTracer::sample_radiance(const Ray& camera_ray, uint64_t pixel, uint32_t sample, const IntegratorSettings& settings,
                                 float* coverage, PathStats* stats) const {
  const Scene& scene = scene_;
  const uint64_t path_key = hash_combine(hash_combine(settings.seed, pixel), sample);
  Scatterer scatterer(scene_, *accel_, settings, mesh_epsilon_);

  Vec3 L(0.0f), beta(1.0f);
  Ray ray = camera_ray;
  SpawnContext spawn;  // the camera ray leaves no surface
  float prev_brdf_pdf = 0.0f;  // density of the BRDF sample that produced `ray` (0: camera ray)
  if (coverage) *coverage = 0.0f;
  if (stats) stats->paths++;

  for (int bounce = 0;; ++bounce) {
    // Next event along the ray: a Gaussian interaction, a mesh, or an escape.
    NextEvent ev = scatterer.next_event(ray, spawn, path_key, uint32_t(bounce));
    if (bounce == 0 && coverage) *coverage = (ev.kind == NextEvent::Gaussian || ev.kind == NextEvent::Mesh) ? 1.0f : 0.0f;

    // Lights in front of the event (hit by the BRDF sample or the camera ray), MIS-weighted.
    LightHit lh;
    if (closest_light_hit(scene.emitters, ray, ev.t, &lh)) {
      float w = prev_brdf_pdf > 0.0f ? power_heuristic(1, prev_brdf_pdf, 1, lh.pdf) : 1.0f;
      L += beta * lh.Le * w;
      break;
    }
    if (ev.kind == NextEvent::Absorbed) break;
    // Escape: the environment, MIS-weighted against its own sampling.
    if (ev.kind == NextEvent::Escape) {
      Vec3 Le = environment_radiance(scene.environment, ray.d);
      float w = prev_brdf_pdf > 0.0f ? power_heuristic(1, prev_brdf_pdf, 1, environment_pdf(scene.environment, ray.d)) : 1.0f;
      L += beta * Le * w;
      break;
    }
    // Emissive meshes are reached by BRDF sampling only (no MIS partner).
    if (ev.kind == NextEvent::Mesh) L += beta * ev.emission;
    if (bounce > settings.max_bounces) break;

    // Shade the interaction in its local frame.
    if (stats) stats->vertices++;
    Frame frame(ev.n);
    Vec3 wo = frame.to_local(-ray.d);
    DisneyParams brdf{ev.albedo, ev.roughness, ev.metallic};
    SpawnContext here = scatterer.spawn_context(ev, ray);

    // Next-event estimation: one sample of every light and of the environment.
    L += beta * scatterer.direct_light(here, frame, wo, brdf, path_key, uint32_t(bounce), stats);

    // Continue with a BRDF sample.
    Rng rng(path_key, uint64_t(bounce), kStreamBrdf);
    DisneySample bs = disney_sample(brdf, wo, rng.at(0), rng.at(1), rng.at(2));
    if (!bs.valid) break;
    beta *= bs.weight;
    if (max_component(beta) < settings.min_throughput) break;
    prev_brdf_pdf = bs.pdf;
    ray = scatterer.spawn_ray(here, frame.to_world(bs.wi));
    spawn = here;
  }
  return L;
}

}  // namespace ptir
