#include "ptir/transport/scattering.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "ptir/math/path_sampler.h"
#include "ptir/math/sampling.h"
#include "ptir/scene/mesh_surface.h"
#include "ptir/transport/gradient_tile.h"
#include "ptir/transport/path_tracer.h"
#include "ptir/transport/shading_normal.h"
#include "ptir/transport/walk_store.h"

namespace ptir {

namespace {

// Fixed-offset variant (PTIR code): skipped hits must face away by more than this.
constexpr float kFixedBackfaceCos = 0.1f;

Vec3 mesh_emission(const TriangleMesh& mesh, const MeshHit& hit, Vec3 d) {
  // One-sided like Blender's emission: only the front of the triangle emits.
  if (mesh.material.emission.x <= 0 && mesh.material.emission.y <= 0 && mesh.material.emission.z <= 0) return Vec3(0.0f);
  return dot(mesh.face_normal(hit.prim), d) < 0.0f ? mesh.material.emission : Vec3(0.0f);
}

}  // namespace

Scatterer::Scatterer(const Scene& scene, const SceneAccel& accel, const IntegratorSettings& settings, float mesh_epsilon,
                     const Vec3* field_radiance)
    : scene_(scene),
      accel_(accel),
      field_(accel.field()),
      settings_(settings),
      mesh_epsilon_(mesh_epsilon),
      field_radiance_(settings.indirect_from_field ? field_radiance : nullptr) {
  lights_ = uint32_t(scene.emitters.size()) + (scene.environment.present() ? 1u : 0u);
  light_pick_ = settings.light_selection == LightSelection::One && lights_ > 1 ? 1.0f / float(lights_) : 1.0f;
  emissive_meshes_ = false;
  for (const TriangleMesh& m : accel.meshes()) emissive_meshes_ |= max_component(m.material.emission) > 0.0f;
}

bool Scatterer::is_self_hit(const SpawnContext& from, Vec3 d, const GaussianHit& h) const {
  if (from.kind != SpawnContext::Gaussian) return false;
  // A hit is the surface left when the ray leaves it through the side the vertex
  // was shaded from: its normal points along d -- a signed normal (from the file)
  // as it is, an unsigned one (two-sided splats) taken on the side of the vertex's
  // normal from.n. The range test first: most hits lie beyond it, and need no
  // normal fetched.
  const auto leaves = [&](float cos_min) {
    const Vec3 n = field_.normal[h.id];
    const float c = dot(d, n);
    return (field_.normals_from_file || dot(n, from.n) >= 0.0f ? c : -c) > cos_min;
  };
  if (settings_.self_intersection == SelfIntersection::BackfaceAware)
    return h.t > 0.0f && h.t <= from.self_range && leaves(0.0f);
  return h.t <= settings_.fixed_range && leaves(kFixedBackfaceCos);
}

InteractionBuilder Scatterer::interaction_builder(Vec3 incoming, uint64_t path_key, uint32_t bounce,
                                                 std::vector<WeightedHit>* record) const {
  InteractionSettings isettings = settings_.interaction;
  if (!settings_.geometric_criterion) isettings.tau_g = 0.0f;  // ablation: any response forms an interaction
  uint64_t pick_key = hash_combine(hash_combine(path_key, bounce), kStreamPick);
  // Only the rays leaving a vertex end on the splats' radiance (indirect_from_field).
  const Vec3* radiance = bounce > 0 ? field_radiance_ : nullptr;
  return InteractionBuilder(field_, isettings, accel_.settings().cull.min_transmittance, incoming, pick_key, record,
                            radiance);
}

NextEvent Scatterer::next_event(const Ray& ray, const SpawnContext& from, uint64_t path_key, uint32_t bounce,
                                std::vector<WeightedHit>* record, WalkCapture* capture) const {
  InteractionBuilder builder = interaction_builder(ray.d, path_key, bounce, record);
  // Composite the Gaussians front to back, skipping the surface the ray leaves
  // (dropped inside the traversal, so that the walk can stop where the ray turns
  // opaque and prune the BVH behind it: the same hits reach the builder).
  const auto self_hit = [&](const GaussianHit& h) { return is_self_hit(from, ray.d, h); };
  const HitTest skip = hit_test(self_hit);
  if (capture) capture->hits.clear();
  const auto visit = [&](const GaussianHit& h) {
    if (capture) capture->hits.push_back(h);
    return builder.add(h);
  };
  WalkEnd end = accel_.walk(ray, visit, nullptr, /*stop_when_opaque=*/true,
                            from.kind == SpawnContext::Gaussian ? &skip : nullptr);
  if (capture) capture->end = end;
  return classify(ray, builder.finish(ray), end, path_key, bounce);
}

NextEvent Scatterer::recorded_event(const Ray& ray, const std::vector<GaussianHit>& hits, const WalkEnd& end,
                                    uint64_t path_key, uint32_t bounce, std::vector<WeightedHit>* record) const {
  InteractionBuilder builder = interaction_builder(ray.d, path_key, bounce, record);
  for (const GaussianHit& h : hits) builder.add(h);  // the walk's own hits, in its order
  return classify(ray, builder.finish(ray), end, path_key, bounce);
}

bool Scatterer::escapes(const Ray& ray, const SpawnContext& from, uint64_t path_key, uint32_t bounce) const {
  // next_event escapes when O = 1 - T <= tau_g (no valid interaction; classify), then
  // when chi_pass's uniform xi < T (or nothing was hit), and no triangle ends the walk.
  const float tau = settings_.geometric_criterion ? settings_.interaction.tau_g : 0.0f;
  const float xi = PathRng(path_key, bounce, kStreamPass).at(0);
  float T = 1.0f;
  // Each accepted hit (the walk's own, skipping the surface left) lowers T; the
  // query ends at the first hit after which the ray can no longer escape.
  const auto ends_escape = [&](const GaussianHit& h) {
    if (is_self_hit(from, ray.d, h)) return false;
    T *= 1.0f - h.alpha;
    return 1.0f - T > tau || !(xi < T);
  };
  return !accel_.occluded(ray, hit_test(ends_escape));
}

void Scatterer::camera_events(const Ray* rays, int n, const uint64_t* path_keys, NextEvent* events,
                              std::vector<WeightedHit>* records, WalkCapture* captures) const {
  std::optional<InteractionBuilder> builders[SceneAccel::kMaxPacket];
  for (int l = 0; l < n; ++l) {
    builders[l].emplace(interaction_builder(rays[l].d, path_keys[l], 0, records ? &records[l] : nullptr));
    if (captures) captures[l].hits.clear();
  }
  // The same walk per lane as next_event's (a camera ray skips nothing), the rays traced together.
  WalkEnd ends[SceneAccel::kMaxPacket];
  const auto visit = [&](int l, const GaussianHit& h) {
    if (captures) captures[l].hits.push_back(h);
    return builders[l]->add(h);
  };
  accel_.walk_packet(rays, n, visit, ends, nullptr, /*stop_when_opaque=*/true);
  for (int l = 0; l < n; ++l) {
    if (captures) captures[l].end = ends[l];
    events[l] = classify(rays[l], builders[l]->finish(rays[l]), ends[l], path_keys[l], 0);
  }
}

NextEvent Scatterer::classify(const Ray& ray, const SurfaceInteraction& si, const WalkEnd& end, uint64_t path_key,
                              uint32_t bounce) const {
  NextEvent ev;
  ev.si = si;
  // A valid Gaussian interaction (chi_geom = 1).
  if (si.valid) {
    ev.kind = NextEvent::Gaussian;
    ev.t = si.depth;
    ev.p = si.p;
    ev.n = ev.ng = ev.ns = ev.nm = si.n;
    ev.material = {si.albedo, si.roughness, si.metallic, si.specular, si.specular_tint};
    ev.shader = field_.shader;
    ev.size = si.size;
    return ev;
  }
  // chi_pass: through the field with probability T_ray, else absorbed.
  if (si.opacity > 0.0f && !(PathRng(path_key, bounce, kStreamPass).at(0) < si.transmittance)) {
    ev.kind = NextEvent::Absorbed;
    ev.t = si.opacity > 0.0f ? si.depth : ray.tmax;
    return ev;
  }
  if (end.mesh.valid) {
    const TriangleMesh& mesh = accel_.meshes()[end.mesh.mesh];
    // The face's normal toward the ray; the shading normal (interpolated on a smooth
    // mesh) on the same side of the face.
    Vec3 ng = mesh.face_normal(end.mesh.prim);
    if (dot(ng, ray.d) > 0.0f) ng = -ng;
    ev.kind = NextEvent::Mesh;
    ev.mesh = end.mesh;
    ev.t = end.mesh.t;
    ev.p = ray.at(end.mesh.t);
    ev.ng = ng;
    // The shading normal and the textured inputs at the hit (scene/mesh_surface.h);
    // a normal other than the face's gets the BSDF's reflection correction.
    const MeshSurface surface = mesh_surface(mesh, end.mesh.prim, end.mesh.u, end.mesh.v, ray.d, ng);
    ev.ns = surface.ns;
    ev.nm = surface.n;
    ev.n = mesh.smooth() || mesh.material.normal_map ? valid_reflection_normal(ng, -ray.d, surface.n) : ng;
    ev.material = surface.material;
    ev.shader = mesh.material.shader;
    ev.emission = mesh_emission(mesh, end.mesh, ray.d);
    return ev;
  }
  ev.kind = NextEvent::Escape;
  return ev;
}

SpawnContext Scatterer::spawn_context(const NextEvent& ev, const Ray& incoming) const {
  SpawnContext s;
  s.p = ev.p;
  if (ev.kind == NextEvent::Mesh) {
    s.kind = SpawnContext::Mesh;
    s.ng = ev.ng;
  } else {
    s.kind = SpawnContext::Gaussian;
    s.n = ev.n;
    s.self_range = settings_.self_range_scale * ev.size;
    if (std::isnan(s.self_range)) s.self_range = INFINITY;  // inf * 0
  }
  return s;
}

Ray Scatterer::spawn_ray(const SpawnContext& from, Vec3 wi, float max_distance) const {
  Ray r;
  r.o = from.p;
  r.d = wi;
  r.tmin = 0.0f;
  r.tmax = max_distance;
  if (from.kind == SpawnContext::Mesh) {
    // Leave the triangle on the side of wi; the scene-scaled offset avoids re-hitting it.
    r.o = from.p + (dot(from.ng, wi) >= 0.0f ? from.ng : -from.ng) * mesh_epsilon_;
  } else if (from.kind == SpawnContext::Gaussian && settings_.self_intersection == SelfIntersection::FixedOffset) {
    r.o = from.p + wi * settings_.fixed_offset;
    if (std::isfinite(max_distance)) r.tmax = std::max(0.0f, max_distance - settings_.fixed_offset);
  }
  return r;
}

bool Scatterer::unoccluded(const SpawnContext& from, Vec3 wi, float distance, uint64_t path_key, uint32_t bounce,
                           uint32_t light) const {
  // Stop short of a light surface so it does not occlude itself.
  float max_t = std::isfinite(distance) ? distance * (1.0f - 1e-4f) : distance;
  Ray r = spawn_ray(from, wi, max_t);
  const uint64_t key = hash_combine(hash_combine(hash_combine(path_key, bounce), kStreamShadow), light);
  // Each Gaussian occludes with probability alpha, decided by a hash of its id, so
  // the answer does not depend on the order of the hits: an occlusion query, which
  // stops at the first occluder Embree meets.
  const auto occludes = [&](const GaussianHit& h) {
    return to_unit_float(hash_combine(key, h.id)) < h.alpha && !is_self_hit(from, wi, h);
  };
  return !accel_.occluded(r, hit_test(occludes));
}

namespace {

// A light sample's slot in the path's outcome log (ShadowLog): the primal records
// whether the sample contributed (valid, f~ > 0, shadow ray unoccluded); the
// replay skips a sample that did not (no sampling, no BSDF evaluation: it added
// nothing) and, for one that did, knows its shadow ray is unoccluded. Without a
// log, or past its 64 entries, everything is computed and traced.
struct LightSlot {
  ShadowLog* log;
  bool known = false;        // replay: the primal's outcome was read
  bool contributes = false;  // replay: what it was
  explicit LightSlot(ShadowLog* l) : log(l) {
    if (log && log->replay) known = log->recall(&contributes);
  }
  bool skip() const { return known && !contributes; }
  template <class Trace>
  bool unoccluded(Trace&& trace) const { return known || trace(); }
  void record(bool contributed) const {
    if (log && !log->replay) log->record(contributed);
  }
};

}  // namespace

Vec3 Scatterer::direct_light(const SpawnContext& from, const Frame& frame, const Bsdf& bsdf, uint64_t path_key,
                             uint32_t bounce, PathStats* stats, const DirectAdjoint* adjoint, ShadowLog* shadows,
                             LightSampleLog samples) const {
  Vec3 Ld(0.0f);
  const auto& emitters = scene_.emitters;
  const SceneEnvironment& env = scene_.environment;
  // The lights sampled here: all of them, or one picked uniformly (stratified over
  // the pixel's samples) whose estimate is divided by the pick's probability.
  uint32_t first = 0, last = lights_;
  const float pick = light_pick_;
  if (pick < 1.0f) {
    first = std::min(uint32_t(PathRng(path_key, bounce, kStreamLightPick).at(0) * float(lights_)), lights_ - 1);
    last = first + 1;
  }

  // A contributing sample of light l: direction wi, radiance Li, MIS weight / pdf
  // (what the walk store keeps); adds f~ Li w / pdf and, in the replay, the adjoints.
  const auto contribute = [&](uint32_t l, Vec3 wi, Vec3 Li, float w_pdf, Vec3 wi_local, const Vec3* f_known) {
    const bool environment = l >= emitters.size();
    Vec3 f;
    if (!adjoint) {
      f = f_known ? *f_known : bsdf.eval(wi_local);
    } else if (!environment) {
      // Adjoint: d(contribution)/d f~ = beta Li w / pdf (pdfs and weights fixed).
      f = bsdf.eval_grad(wi_local, adjoint->dL * adjoint->beta * Li * w_pdf, *adjoint->brdf);
    } else {
      // Adjoint: into the BRDF (through f~) and into the environment (through Li).
      const Vec3 scale = adjoint->dL * adjoint->beta * w_pdf;
      f = bsdf.eval_grad(wi_local, scale * Li, *adjoint->brdf);
      if (adjoint->grads) adjoint->grads->add_environment(wi, scale * f);
    }
    Ld += f * Li * w_pdf;
  };

  // Light l's sample; returns whether it contributed (valid, f~ > 0, unoccluded),
  // with its direction, radiance and MIS weight / pdf. Emitters: MIS against the
  // BRDF density (delta lights: weight 1); the environment (light index N - 1):
  // importance-sampled direction, MIS against the BRDF density.
  const auto sample = [&](uint32_t l, const LightSlot& slot, Vec3* wi, Vec3* Li, float* w_pdf, BsdfEvalPdf* fp) {
    PathRng rng(path_key, bounce, kStreamLight + l);
    float light_pdf, distance = INFINITY;
    bool delta = false;
    if (l < emitters.size()) {
      const LightSample ls = sample_li(emitters[l], from.p, rng.at(0), rng.at(1));
      if (!ls.valid()) return false;
      *wi = ls.wi, *Li = ls.Li, light_pdf = ls.pdf, distance = ls.distance, delta = ls.delta;
    } else {
      const EnvLightSample es = env->sample_li(rng.at(0), rng.at(1), rng.at(2));
      if (!(es.pdf > 0.0f)) return false;
      *wi = es.wi, *Li = es.Li, light_pdf = es.pdf;
    }
    // Below the face (a smooth mesh's shading normal can lean past it): no light
    // passes through the surface (flat faces: the BSDF is zero there anyway).
    if (from.kind == SpawnContext::Mesh && !(dot(*wi, from.ng) > 0.0f)) return false;
    *fp = bsdf.eval_pdf(frame.to_local(*wi));
    if (!(max_component(fp->f) > 0.0f)) return false;
    if (stats && !slot.known) stats->shadow_rays++;
    if (!slot.unoccluded([&] { return unoccluded(from, *wi, distance, path_key, bounce, l); })) return false;
    const float pdf = pick * light_pdf;
    *w_pdf = (delta ? 1.0f : power_heuristic(1, pdf, 1, fp->pdf)) / pdf;
    return true;
  };

  for (uint32_t l = first; l < last; ++l) {
    const LightSlot slot(shadows);
    Vec3 wi, Li;
    float w_pdf;
    if (samples.in) {  // replay of a kept path: the primal's sample, as it was
      if (samples.in->next_light(&wi, &Li, &w_pdf)) contribute(l, wi, Li, w_pdf, frame.to_local(wi), nullptr);
      continue;
    }
    if (slot.skip()) continue;
    BsdfEvalPdf fp;
    const bool contributed = sample(l, slot, &wi, &Li, &w_pdf, &fp);
    if (contributed) contribute(l, wi, Li, w_pdf, frame.to_local(wi), &fp.f);
    slot.record(contributed);
    if (samples.out) samples.out->add_light(contributed, wi, Li, w_pdf);
  }
  return Ld;
}

}  // namespace ptir
