// The adjoints gathered by one fixed tile of work (a block of pixels) during
// path replay, held sparsely: only the Gaussians the tile's paths met have an
// entry. render/tile_reduce.h adds the tiles into the dense SceneGradients in
// tile order, so the memory of a replay is (tiles in flight) x (Gaussians one
// tile touches), not (threads) x (all Gaussians), and the sums do not depend on
// the thread count.
#pragma once

#include <cstdint>
#include <vector>

#include "ptir/math/vec.h"
#include "ptir/transport/gradients.h"

namespace ptir {

class GradientTile {
 public:
  // Buffers shaped like `like` (its Gaussian/mesh/environment sizes); env is
  // the model whose adjoint() receives environment adjoints (may be empty).
  GradientTile(const SceneGradients& like, const SceneEnvironment& env);

  // Empties the tile, keeping its allocations.
  void clear();

  void add_gaussian(uint32_t id, Vec3 d_albedo, float d_roughness, float d_metallic);
  void add_mesh(uint32_t mesh, Vec3 d_base_colour, float d_roughness, float d_metallic);
  // The adjoint d_Le of the environment radiance seen along d.
  void add_environment(Vec3 d, Vec3 d_Le);

  // Orders the Gaussian entries by id (so the reduction walks the dense arrays
  // forward), at the front of the table; call once, after the last add.
  void finish();
  // grads += this tile. Each parameter receives at most one addition per tile
  // (environment: its adjoint calls replayed in the order they were made), so
  // adding tiles in a fixed order gives the same floats on any thread count.
  void add_to(SceneGradients& grads) const;

  size_t gaussian_entries() const { return count_; }
  size_t bytes() const;  // heap held by the tile

 private:
  // One environment adjoint call: the adjoint d_Le of the radiance seen along d.
  struct EnvRecord {
    Vec3 d, d_Le;
  };
  struct Entry {  // 24 bytes
    uint32_t id;   // kEmpty: a free slot of the table
    Vec3 albedo;
    float roughness, metallic;
  };
  static constexpr uint32_t kEmpty = 0xFFFFFFFFu;
  void grow();

  const SceneEnvironment* env_ = nullptr;
  // Open addressing with the entries in the table itself (one cache line per add,
  // not a slot and then an entry), load factor <= 1/2.
  std::vector<Entry> table_;
  size_t count_ = 0;             // entries in the table
  uint32_t shift_ = 0;           // 32 - log2(table_.size())
  std::vector<Vec3> mesh_base_colour_;
  std::vector<float> mesh_roughness_, mesh_metallic_;
  bool mesh_touched_ = false;
  // Environment: a dense buffer when the model has few parameters (SG, constant,
  // small maps), else a log of adjoint calls replayed by add_to (large maps).
  std::vector<float> env_dense_;
  std::vector<EnvRecord> env_log_;
  bool env_touched_ = false;
};

}  // namespace ptir
