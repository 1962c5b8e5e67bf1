// What one path sample's replay reuses from its primal, behind one interface
// (PathTracer::trace): the outcome of each ray (escaped or not, shadow rays
// unoccluded or not), the walk to each vertex, its light samples and its BSDF
// sample. The primal samples them and records them; the replay reads the record
// back where there is one and samples (with the same random numbers) where there
// is none, so both see the same decisions and trace stays about light.
#pragma once

#include <cstdint>
#include <vector>

#include "ptir/material/bsdf.h"
#include "ptir/math/path_sampler.h"
#include "ptir/transport/path_tracer.h"
#include "ptir/transport/scattering.h"
#include "ptir/transport/walk_store.h"

namespace ptir {

class PathRecord {
 public:
  // Primal (adjoint null): records into io.shadow_bits (the ray outcomes) and
  // io.walks (what the replay needs; none when the camera ray's event is given
  // without its walk). Replay: reads the adjoint's outcomes and walks. io.first:
  // the camera ray's event, already found in a packet, with its Gaussians (replay)
  // or its walk (primal).
  PathRecord(const PathAdjoint* adjoint, const PathRecordIO& io)
      : replay_(adjoint != nullptr),
        shadow_bits_(adjoint ? nullptr : io.shadow_bits),
        walks_out_(adjoint || (io.first && !io.first_walk) ? nullptr : io.walks),
        walks_in_(adjoint ? adjoint->walks : PathWalkReader()),
        first_(io.first),
        first_hits_(io.first_hits),
        first_walk_(io.first_walk),
        vertex_hits_(thread_vertex_hits()),
        walk_(thread_walk()) {
    if (io.walks) io.walks->clear();  // (empty: nothing kept)
    if (adjoint && adjoint->shadow_bits) {
      outcomes_.bits = *adjoint->shadow_bits;
      outcomes_.replay = true;
      shadows_ = &outcomes_;
    } else if (!adjoint && io.shadow_bits) {
      shadows_ = &outcomes_;
    }
  }

  // Replay: whether the next ray escaped, when the primal recorded it (false: unknown, trace it).
  bool recall_escape(bool* escaped) { return shadows_ && shadows_->replay && shadows_->recall(escaped); }
  // Primal: the next ray's outcome.
  void record_escape(bool escaped) {
    if (shadows_ && !shadows_->replay) shadows_->record(escaped);
  }

  // The next event along `ray`: the given camera event, the primal's walk read back
  // (replay, when the walk was kept: walk_kept), or walked (and, in the primal, kept).
  NextEvent next_event(const Scatterer& scatterer, const Ray& ray, const SpawnContext& spawn, uint64_t path_key,
                       int bounce, bool walk_kept) {
    const bool given = bounce == 0 && first_;
    hits_ = given && first_hits_ ? first_hits_ : &vertex_hits_;
    vertex_hits_.clear();
    NextEvent ev;
    if (given) {
      ev = *first_;
    } else if (walks_in_.recorded() && walk_kept) {
      if (walks_in_.next(&walk_.hits, &walk_.end))
        ev = scatterer.recorded_event(ray, walk_.hits, walk_.end, path_key, uint32_t(bounce), &vertex_hits_);
      else
        ev.kind = NextEvent::Escape;
    } else {
      ev = scatterer.next_event(ray, spawn, path_key, uint32_t(bounce), replay_ ? &vertex_hits_ : nullptr,
                                walks_out_ && walk_kept ? &walk_ : nullptr);
    }
    if (walks_out_ && walk_kept) {
      const WalkCapture& w = given ? *first_walk_ : walk_;
      walks_out_->add(w.hits.data(), w.hits.size(), w.end, ev.kind == NextEvent::Escape);
    }
    record_escape(ev.kind == NextEvent::Escape);
    return ev;
  }
  // The last event's Gaussians (replay: where its BSDF adjoint goes).
  const std::vector<WeightedHit>& hits() const { return *hits_; }

  // Next-event estimation's shadow-ray outcomes and light samples (Scatterer::direct_light).
  ShadowLog* shadows() { return shadows_; }
  LightSampleLog light_samples() { return {walks_out_, walks_in_.recorded() ? &walks_in_ : nullptr}; }

  // The vertex's BSDF sample: the primal's read back, else drawn. face_ng (world; a
  // mesh's face normal, else null): a direction below the face ends the path, as no
  // light comes through the surface (a smooth mesh's shading normal leaning past it;
  // the light samples' rule).
  BsdfSample bsdf_sample(const Bsdf& bsdf, uint64_t path_key, int bounce, const Frame& frame, const Vec3* face_ng) {
    BsdfSample bs;
    if (walks_in_.recorded()) {
      bs = walks_in_.next_bsdf();
    } else {
      PathRng rng(path_key, uint64_t(bounce), kStreamBrdf);
      bs = bsdf.sample(rng.at(0), rng.at(1), rng.at(2));
      if (bs.valid && face_ng && !(dot(frame.to_world(bs.wi), *face_ng) > 0.0f)) bs.valid = false;
    }
    if (walks_out_) walks_out_->add_bsdf(bs);
    return bs;
  }

  // Primal: hands the recorded ray outcomes out.
  void finish() {
    if (shadow_bits_) *shadow_bits_ = outcomes_.bits;
  }

 private:
  static std::vector<WeightedHit>& thread_vertex_hits() {
    thread_local std::vector<WeightedHit> hits;
    return hits;
  }
  static WalkCapture& thread_walk() {
    thread_local WalkCapture walk;
    return walk;
  }

  bool replay_;
  uint64_t* shadow_bits_;
  PathWalkWriter* walks_out_;
  PathWalkReader walks_in_;
  const NextEvent* first_;
  const std::vector<WeightedHit>* first_hits_;
  const WalkCapture* first_walk_;
  std::vector<WeightedHit>& vertex_hits_;  // the current vertex's Gaussians (replay only)
  WalkCapture& walk_;                      // the current walk (recorded, or read back)
  const std::vector<WeightedHit>* hits_ = nullptr;
  ShadowLog outcomes_;
  ShadowLog* shadows_ = nullptr;
};

}  // namespace ptir
