// The pieces of a path vertex shared by the forward path tracer and the
// gradient replay: finding the next event along a ray (Gaussian interaction with
// the chi_geom / chi_pass rules, mesh, escape), spawning rays with the
// self-intersection rule, stochastic-transmittance shadow rays, and next-event
// estimation of every light with MIS.
//
// Random-number streams: every decision draws from PathRng(path_key, bounce, stream)
// (math/path_sampler.h: stratified over the pixel's samples), and a shadow ray's Gaussian occlusion tests from a hash of
// (path_key, bounce, light, Gaussian id), so a replay makes the same decisions.
#pragma once

#include <cstdint>
#include <vector>

#include "ptir/accel/scene_accel.h"
#include "ptir/material/bsdf.h"
#include "ptir/math/rng.h"
#include "ptir/scene/scene.h"
#include "ptir/transport/interaction.h"

namespace ptir {

struct PathStats;
class GradientTile;
struct PathWalkWriter;
class PathWalkReader;

// A path's light samples kept with its walks (walk_store.h): the primal appends
// each one's outcome, direction, radiance and weight; the replay reads them back
// instead of sampling the lights again (the same floats).
struct LightSampleLog {
  PathWalkWriter* out = nullptr;  // primal: append
  PathWalkReader* in = nullptr;   // replay: read
};

// Adjoint inputs of direct_light during gradient replay (docs/method.md §6): the path
// throughput beta and the adjoint dL of the sample's radiance. Light sampling
// densities and MIS weights are held fixed.
struct DirectAdjoint {
  Vec3 beta;
  Vec3 dL;
  MaterialGrad* brdf = nullptr;      // += adjoint of the vertex's BSDF parameters
  GradientTile* grads = nullptr;     // += adjoint of environment texels / SG amplitudes
};

// The ray outcomes of one path, in the order the path meets them: the primal
// pass records them (bit k: the k-th outcome was true) and the replay, which
// meets the same samples in the same order with the same random numbers, reads
// them back instead of tracing again. Two kinds, interleaved: whether a light
// sample contributed (valid, BSDF value > 0, shadow ray unoccluded: the replay
// skips the others whole, scattering.cpp), and whether a continuation ray
// escaped (path_tracer.cpp). Outcomes after the 64th are traced in both passes.
struct ShadowLog {
  uint64_t bits = 0;
  int count = 0;
  bool replay = false;  // read bits (replay) instead of recording them (primal)

  // Primal: records the next outcome.
  void record(bool value) {
    const int k = count++;
    if (k < 64 && value) bits |= uint64_t(1) << k;
  }
  // Replay: the next outcome into *value when it was recorded (else false: trace it).
  bool recall(bool* value) {
    const int k = count++;
    if (k >= 64) return false;
    *value = (bits >> k) & 1u;
    return true;
  }
};

// Random streams of one bounce.
constexpr uint64_t kStreamPass = 1;      // chi_pass: xi < T_ray
constexpr uint64_t kStreamPick = 2;      // discrete interaction pick
constexpr uint64_t kStreamBrdf = 3;      // BRDF sample (3 dimensions)
constexpr uint64_t kStreamLightPick = 4; // which light next-event estimation samples (LightSelection::One)
constexpr uint64_t kStreamRoulette = 5;  // Russian roulette
constexpr uint64_t kStreamLight = 16;    // + light index: light sample (2 dimensions)
constexpr uint64_t kStreamShadow = 1024; // + light index: shadow-ray occlusion hashes

// What a ray meets next.
struct NextEvent {
  enum Kind { Gaussian, Mesh, Escape, Absorbed } kind = Escape;
  float t = std::numeric_limits<float>::infinity();  // ray parameter of the event (inf: escape)
  Vec3 p;           // position
  Vec3 n;           // unit shading normal facing the incoming ray
  Vec3 ng;          // unit geometric normal facing the incoming ray (Gaussians: n; a smooth
                    // mesh: the face's, n put on its side; offsets and side tests use it)
  Vec3 ns;          // a mesh's own normal (face or interpolated) before its normal map and the
                    // reflection correction (Cycles' sd->N); where it differs from n the BSDF's
                    // diffuse lobe carries the bump shadowing term (material/bsdf.h). Gaussians: n
  Vec3 nm;          // a mesh's closure normal before the reflection correction (Principled v2's
                    // diffuse closure keeps it). Gaussians: n
  MaterialParams material;  // albedo, roughness, metallic, specular, specular tint
  SurfaceShader shader = SurfaceShader::PrincipledGGX;
  Vec3 emission;    // mesh emission toward the ray (zero for Gaussians)
  float size = 0.0f;  // Gaussian interaction: w-weighted largest scale of its Gaussians
  SurfaceInteraction si;  // Gaussian interaction details (weights are replayed from it)
  MeshHit mesh;           // mesh details
};

// Where a spawned ray starts and which hits it must not see again.
struct SpawnContext {
  enum Kind { Camera, Gaussian, Mesh } kind = Camera;
  Vec3 p;
  Vec3 ng;                 // mesh: geometric normal facing the ray that arrived
  Vec3 n;                  // Gaussian: the interaction's normal (facing the ray that arrived)
  float self_range = 0.0f; // Gaussian, backface-aware: skip range (inf: the paper's rule)
};

// What a walk handed to the interaction builder, in order, and how it ended: all
// the event depends on (WalkStore keeps it for the replay; Scatterer::recorded_event).
struct WalkCapture {
  std::vector<GaussianHit> hits;
  WalkEnd end;
};

class Scatterer {
 public:
  // mesh_epsilon: offset of rays leaving a mesh (scaled to the scene's size).
  // field_radiance: the splats' own radiance (field_radiance.h), which the
  // interactions of rays leaving a vertex composite with indirect_from_field.
  Scatterer(const Scene& scene, const SceneAccel& accel, const IntegratorSettings& settings, float mesh_epsilon,
            const Vec3* field_radiance = nullptr);

  // Walks `ray` and classifies what it meets (docs/method.md §3–4): a valid Gaussian
  // interaction; else, with probability T_ray, what lies behind (mesh or escape);
  // else the path is absorbed.
  // With `record`, the Gaussians composited are appended with their weights.
  // With `capture`, the walk's hits and end are kept for recorded_event.
  NextEvent next_event(const Ray& ray, const SpawnContext& from, uint64_t path_key, uint32_t bounce,
                       std::vector<WeightedHit>* record = nullptr, WalkCapture* capture = nullptr) const;
  // The event next_event gave when its walk handed over `hits` and ended at `end`
  // (a capture of it): the same floats, nothing traced.
  NextEvent recorded_event(const Ray& ray, const std::vector<GaussianHit>& hits, const WalkEnd& end, uint64_t path_key,
                           uint32_t bounce, std::vector<WeightedHit>* record = nullptr) const;
  // Whether next_event(ray, from, path_key, bounce) escapes, for a ray whose event
  // matters for nothing else (the path's last ray, when no mesh emits and no light
  // lies along it: escape_query_applies). Escape needs every hit's opacity but not
  // their order: T = prod(1 - alpha) must stay >= 1 - tau_g (no valid interaction)
  // and above the chi_pass uniform, and no triangle may be hit; so it is an
  // occlusion query that stops as soon as the answer is no, without a k-buffer.
  // The same event as next_event's up to the rounding of T in another order.
  bool escapes(const Ray& ray, const SpawnContext& from, uint64_t path_key, uint32_t bounce) const;
  // Whether escapes() can stand for next_event on a last ray: no mesh emits.
  bool escape_query_applies() const { return !emissive_meshes_; }

  // next_event of n <= SceneAccel::kMaxPacket camera rays (bounce 0, leaving no
  // surface) at once, traced as one packet (SceneAccel::walk_packet): events[l] and
  // records[l] (when records is given) are exactly what next_event(rays[l], {},
  // path_keys[l], 0, &records[l]) gives. For coherent rays (the samples of one pixel).
  void camera_events(const Ray* rays, int n, const uint64_t* path_keys, NextEvent* events,
                     std::vector<WeightedHit>* records = nullptr, WalkCapture* captures = nullptr) const;

  SpawnContext spawn_context(const NextEvent& ev, const Ray& incoming) const;
  // The ray leaving `from` along unit direction wi (offsets applied).
  Ray spawn_ray(const SpawnContext& from, Vec3 wi, float max_distance = std::numeric_limits<float>::infinity()) const;

  // Stochastic transmittance along the shadow ray from `from` toward wi up to
  // `distance`: true when nothing occludes. Meshes occlude fully; Gaussian i
  // occludes when hash(path_key, bounce, light, i) < alpha_i.
  bool unoccluded(const SpawnContext& from, Vec3 wi, float distance, uint64_t path_key, uint32_t bounce,
                  uint32_t light) const;

  // Next-event estimation: a light sample of one light picked uniformly among the
  // emitters and the environment, or of every one of them (IntegratorSettings::
  // light_selection), each MIS-weighted against BSDF sampling with the light's
  // density times light_pick_probability(); returns the sum of f~ Li w / pdf
  // (beta not applied). shadows: records or replays the shadow-ray outcomes (may
  // be null: traced). samples: keeps or replays the light samples themselves.
  Vec3 direct_light(const SpawnContext& from, const Frame& frame, const Bsdf& bsdf, uint64_t path_key,
                    uint32_t bounce, PathStats* stats, const DirectAdjoint* adjoint = nullptr,
                    ShadowLog* shadows = nullptr, LightSampleLog samples = {}) const;

  // The probability with which next-event estimation samples a given light: 1 / N
  // of the N lights (emitters and environment) with LightSelection::One, else 1.
  // BSDF-sampled rays that reach a light weigh their MIS against its density times this.
  float light_pick_probability() const { return light_pick_; }

  // Whether hit h (t_peak, Gaussian) on a ray spawned from `from` along d is the
  // surface just left, to be skipped: within the skip range, and left through the
  // side the vertex was shaded from (h's normal taken on the side of from.n).
  bool is_self_hit(const SpawnContext& from, Vec3 d, const GaussianHit& h) const;

 private:
  InteractionBuilder interaction_builder(Vec3 incoming, uint64_t path_key, uint32_t bounce,
                                         std::vector<WeightedHit>* record) const;
  // The event a walk found: the interaction its hits formed and how the walk ended.
  NextEvent classify(const Ray& ray, const SurfaceInteraction& si, const WalkEnd& end, uint64_t path_key,
                     uint32_t bounce) const;

  const Scene& scene_;
  const SceneAccel& accel_;
  const GaussianField& field_;
  IntegratorSettings settings_;
  float mesh_epsilon_;  // offset of rays leaving a mesh, scaled to the scene
  uint32_t lights_;     // emitters + the environment when present
  float light_pick_;    // light_pick_probability()
  bool emissive_meshes_;  // some mesh emits (a last ray must then find what it hits)
  const Vec3* field_radiance_;  // null: no radiance composited
};

}  // namespace ptir
