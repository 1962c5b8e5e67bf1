// The path tracer over Gaussians and meshes (docs/method.md §4): equivalent surface
// interactions, the simplified Disney BRDF, next-event estimation of every light
// with MIS (power heuristic) against BRDF sampling at every vertex, stochastic
// transmittance shadow rays through the Gaussians, the chi_pass continuation
// rule, and backface-aware self-intersection rejection.
//
// Random numbers are keyed on (seed, pixel, sample, bounce, dimension), so a
// path is a pure function of its keys: images do not depend on the thread count
// and any path can be replayed exactly (path replay backpropagation).
#pragma once

#include <memory>
#include <vector>

#include "ptir/accel/scene_accel.h"
#include "ptir/scene/scene.h"
#include "ptir/transport/walk_store.h"

namespace ptir {

class GradientTile;
struct NextEvent;
struct WalkCapture;
struct WeightedHit;

// Inputs of the adjoint (replay) mode of one sample: the sample's primal
// radiance L and the adjoint dL of the loss with respect to it.
struct PathAdjoint {
  Vec3 L;
  Vec3 dL;
  GradientTile* grads = nullptr;  // receives the parameter adjoints
  // The sample's shadow-ray outcomes recorded by its primal pass (or null: traced again).
  const uint64_t* shadow_bits = nullptr;
  // The sample's walks recorded by its primal pass (WalkStore; else traced again).
  PathWalkReader walks{};
};

// One path's share of the replay cache (render/replay_cache.h), as PathRecord
// (path_record.h) takes it: where the primal keeps what its replay reuses, and
// the camera ray's event when a packet already found it. All optional.
struct PathRecordIO {
  uint64_t* shadow_bits = nullptr;   // primal: the ray outcomes
  PathWalkWriter* walks = nullptr;   // primal: the walks the replay needs
  // The camera ray's event, already found (camera_events), with its Gaussians
  // (replay) or its walk (primal recording walks).
  const NextEvent* first = nullptr;
  const std::vector<WeightedHit>* first_hits = nullptr;
  const WalkCapture* first_walk = nullptr;
};

struct PathStats {
  uint64_t paths = 0;
  uint64_t vertices = 0;     // surface interactions shaded
  uint64_t shadow_rays = 0;
};

class PathTracer {
 public:
  // Builds the acceleration structure of the scene (which must outlive the tracer).
  explicit PathTracer(const Scene& scene, const AccelSettings& accel_settings = {});

  // Radiance of one camera-ray sample; *coverage gets 1 when the ray found a
  // surface (Gaussian interaction or mesh), else 0. pixel is y * width + x.
  // shadow_bits: receives the path's shadow-ray outcomes for its replay (PathAdjoint::shadow_bits).
  Vec3 sample_radiance(const Ray& camera_ray, uint64_t pixel, uint32_t sample, const IntegratorSettings& settings,
                       float* coverage = nullptr, PathStats* stats = nullptr, uint64_t* shadow_bits = nullptr) const;

  // Path replay backpropagation of one sample (docs/method.md §6): replays the path with
  // the same random numbers, starting from the primal radiance adjoint.L and
  // subtracting every contribution as it is passed, and accumulates the adjoints
  // of the materials met (redistributed to the contributing Gaussians with their
  // normalised weights, or to the picked one) and of the environment. Memory does
  // not grow with the bounce count. Held fixed: sampling densities, MIS weights,
  // visibility and validity decisions, and the sampled directions (no
  // reparameterisation term for roughness).
  void sample_adjoint(const Ray& camera_ray, uint64_t pixel, uint32_t sample, const IntegratorSettings& settings,
                      const PathAdjoint& adjoint) const;

  // sample_radiance / sample_adjoint of n camera rays at once (the samples of one
  // pixel, or any coherent rays): their first walks are traced as packets of up
  // to SceneAccel::kMaxPacket rays (about twice as fast as one by one), the rest
  // of each path alone. Each sample gets exactly the result of the single call
  // (same hits, same floats). coverage, shadow_bits and walks may be null, else n
  // long; walks[i] receives the walks of sample i's path for its replay (WalkStore).
  void sample_radiance_batch(const Ray* camera_rays, int n, const uint64_t* pixels, const uint32_t* samples,
                             const IntegratorSettings& settings, Vec3* L, float* coverage = nullptr,
                             PathStats* stats = nullptr, uint64_t* shadow_bits = nullptr,
                             PathWalkWriter* walks = nullptr) const;
  void sample_adjoint_batch(const Ray* camera_rays, int n, const uint64_t* pixels, const uint32_t* samples,
                            const IntegratorSettings& settings, const PathAdjoint* adjoints) const;

  const Scene& scene() const { return scene_; }
  const SceneAccel& accel() const { return *accel_; }
  // The splats' own radiance per Gaussian (null without SH): field_radiance.h.
  const Vec3* radiance() const { return field_radiance_.empty() ? nullptr : field_radiance_.data(); }

 private:
  // What one path reads and writes besides its radiance (all optional).
  struct TraceIO {
    float* coverage = nullptr;
    PathStats* stats = nullptr;
    PathRecordIO record;  // the primal's share of the replay cache; the camera ray's event
  };
  // The path in either mode: primal (adjoint == nullptr) returns L; replay
  // accumulates gradients (one routine, so the two can never disagree).
  Vec3 trace(const Ray& camera_ray, uint64_t pixel, uint32_t sample, const IntegratorSettings& settings,
             const PathAdjoint* adjoint, const TraceIO& io) const;

  const Scene& scene_;
  std::unique_ptr<SceneAccel> accel_;
  float mesh_epsilon_ = 1e-4f;  // offset of rays leaving a mesh, relative to the scene's size
  // The splats' own radiance (field_radiance.h) for indirect_from_field; empty
  // when the field has no SH (the option then changes nothing).
  std::vector<Vec3> field_radiance_;
};

}  // namespace ptir
