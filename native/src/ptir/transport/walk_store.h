// What the primal pass's walks met, kept for the replay (path replay
// backpropagation without tracing the walks again).
//
// A path's replay walks the same rays as its primal (same random numbers, same
// decisions) to rebuild each vertex's interaction and the Gaussians it blends.
// The interaction is a pure function of the hits a walk hands to the
// InteractionBuilder (t_peak, alpha, id, in order) and of how the walk ended
// (a mesh, or nothing), so the primal keeps exactly those and the replay feeds
// them to a builder again: the same floats, no BVH traversal, no Gaussian tests.
//
// Layout of one path (32-bit words, in the order the path meets its walks):
// for every walk at bounce <= max_bounces (the ones the replay needs), a header
// word -- hit count (bits 0..27), kEscaped, kStopped, kMesh -- then 3 words per
// hit (t, alpha, id) unless escaped (an escape needs no hits), then 5 words of
// mesh hit (t, mesh, prim, u, v) when kMesh. After the walk that found a vertex,
// the vertex's light samples (next-event estimation, in the order it takes
// them): one word, 1 when the sample contributed, then 7 words (wi, Li, w / pdf)
// when it did, so the replay neither samples the light nor evaluates its density
// again; then the vertex's BSDF sample: one word, 1 when valid, then 7 words
// (wi, weight, pdf). Paths are kept whole or not at all,
// in fixed chunks, within a byte budget: a path over budget is simply not kept,
// and its replay traces (the same result either way).
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include <tbb/enumerable_thread_specific.h>

#include "ptir/accel/scene_accel.h"
#include "ptir/material/material_params.h"
#include "ptir/math/vec.h"

namespace ptir {

// Header flags of a recorded walk.
constexpr uint32_t kWalkEscaped = 1u << 31;  // the event was an escape (no hits kept)
constexpr uint32_t kWalkStopped = 1u << 30;  // WalkEnd::stopped
constexpr uint32_t kWalkMesh = 1u << 29;     // WalkEnd::mesh valid (5 words follow the hits)
constexpr uint32_t kWalkCountMask = (1u << 28) - 1u;

// A path's walks being recorded (primal): append, then WalkStore::keep.
struct PathWalkWriter {
  std::vector<uint32_t> words;
  void clear() { words.clear(); }
  // One walk: the hits handed to the builder, in order, and how it ended.
  void add(const GaussianHit* hits, size_t n, const WalkEnd& end, bool escaped);
  // One light sample: whether it contributed, and then its direction, radiance and MIS weight / pdf.
  void add_light(bool contributed, Vec3 wi, Vec3 Li, float weight);
  // The vertex's BSDF sample (the direction the path goes on in).
  void add_bsdf(const BsdfSample& bs);
};

// Reads a recorded path's walks back in order (replay).
class PathWalkReader {
 public:
  PathWalkReader() = default;
  explicit PathWalkReader(const uint32_t* at) : at_(at) {}
  bool recorded() const { return at_ != nullptr; }
  // The next walk: its hits (into *hits), its end; returns false when it escaped.
  bool next(std::vector<GaussianHit>* hits, WalkEnd* end);
  // The next light sample: false when it did not contribute, else its wi, Li, w / pdf.
  bool next_light(Vec3* wi, Vec3* Li, float* weight);
  // The next BSDF sample.
  BsdfSample next_bsdf();

 private:
  const uint32_t* at_ = nullptr;
};

// The recorded paths of one render (one slot per sample, like the sample radiance).
class WalkStore {
 public:
  // chunk_bytes: the unit each thread claims (1 MB; small ones for tests of the budget).
  explicit WalkStore(size_t budget_bytes = size_t(256) << 20, size_t chunk_bytes = size_t(1) << 20)
      : chunk_words_(std::max<size_t>(chunk_bytes / sizeof(uint32_t), 1)), budget_words_(budget_bytes / sizeof(uint32_t)) {}
  WalkStore(const WalkStore&) = delete;
  WalkStore& operator=(const WalkStore&) = delete;

  // Empties the store for `samples` slots (keeping its memory for reuse, up to the budget).
  void reset(size_t samples);
  void set_budget(size_t bytes) { budget_words_ = bytes / sizeof(uint32_t); }
  size_t size() const { return slots_.size(); }
  // Keeps sample i's path if the budget allows (thread-safe for distinct i; each
  // thread fills a chunk of its own, so threads share nothing but the chunk list).
  void keep(size_t i, const PathWalkWriter& path);
  // Sample i's path (a reader of nothing when it was not kept).
  PathWalkReader path(size_t i) const { return PathWalkReader(i < slots_.size() ? slots_[i] : nullptr); }

  size_t kept() const;  // samples whose path was kept
  size_t bytes() const { return used_words_.load() * sizeof(uint32_t); }  // in chunks in use

 private:
  struct Cursor {
    uint32_t* at = nullptr;
    size_t left = 0;  // words left in the thread's chunk
  };
  uint32_t* claim(size_t words);  // contiguous room in this thread's chunk, or nullptr over budget

  size_t chunk_words_;
  size_t budget_words_;
  std::vector<const uint32_t*> slots_;
  tbb::enumerable_thread_specific<Cursor> cursors_;
  std::mutex mutex_;  // guards chunks_ (a new chunk per thread per MB)
  std::vector<std::unique_ptr<uint32_t[]>> chunks_;
  std::vector<std::unique_ptr<uint32_t[]>> spare_;  // chunks of earlier renders, reused
  std::atomic<size_t> used_words_{0};  // words in chunks handed out
  std::atomic<bool> full_{false};      // the budget refused a chunk
};

}  // namespace ptir
