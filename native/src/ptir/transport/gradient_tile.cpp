#include "ptir/transport/gradient_tile.h"

#include <algorithm>

namespace ptir {

namespace {

// Environments with at most this many parameters get a dense per-tile buffer
// (128 KB: 24 SGs, a constant, maps up to 128 x 85); larger maps log their
// adjoint calls instead (24 bytes each, a few per path), which costs less than
// adding a whole map per tile.
constexpr size_t kDenseEnvironmentFloats = size_t(1) << 15;

constexpr uint32_t kInitialSlotsLog2 = 10;

// Runs of 8 consecutive ids take 8 consecutive slots (three cache lines), the runs
// scattered by a multiplicative hash: the Gaussians one path vertex composites are
// neighbours, often near in id (files written in spatial order), so their adds
// share cache lines instead of each missing the cache. The slot never changes a
// sum: finish() orders the entries by id.
uint32_t slot_of(uint32_t id, uint32_t shift) {
  return ((id >> 3) * 0x9E3779B1u) >> (shift + 3) << 3 | (id & 7u);  // the table has >= 1024 slots
}

}  // namespace

GradientTile::GradientTile(const SceneGradients& like, const SceneEnvironment& env) {
  mesh_base_colour_.assign(like.mesh_base_colour.size(), Vec3(0.0f));
  mesh_roughness_.assign(like.mesh_roughness.size(), 0.0f);
  mesh_metallic_.assign(like.mesh_metallic.size(), 0.0f);
  if (env.present() && !like.environment.empty()) {
    env_ = &env;
    if (like.environment.size() <= kDenseEnvironmentFloats) env_dense_.assign(like.environment.size(), 0.0f);
  }
  table_.assign(size_t(1) << kInitialSlotsLog2, Entry{kEmpty, Vec3(0.0f), 0.0f, 0.0f});
  shift_ = 32 - kInitialSlotsLog2;
}

void GradientTile::clear() {
  if (count_ > 0) std::fill(table_.begin(), table_.end(), Entry{kEmpty, Vec3(0.0f), 0.0f, 0.0f});
  count_ = 0;
  if (mesh_touched_) {
    std::fill(mesh_base_colour_.begin(), mesh_base_colour_.end(), Vec3(0.0f));
    std::fill(mesh_roughness_.begin(), mesh_roughness_.end(), 0.0f);
    std::fill(mesh_metallic_.begin(), mesh_metallic_.end(), 0.0f);
  }
  mesh_touched_ = false;
  if (env_touched_) std::fill(env_dense_.begin(), env_dense_.end(), 0.0f);
  env_log_.clear();
  env_touched_ = false;
}

void GradientTile::grow() {
  std::vector<Entry> old(table_.size() * 2, Entry{kEmpty, Vec3(0.0f), 0.0f, 0.0f});
  old.swap(table_);
  --shift_;
  const uint32_t mask = uint32_t(table_.size() - 1);
  for (const Entry& e : old) {
    if (e.id == kEmpty) continue;
    uint32_t s = slot_of(e.id, shift_);
    while (table_[s].id != kEmpty) s = (s + 1) & mask;
    table_[s] = e;
  }
}

void GradientTile::add_gaussian(uint32_t id, Vec3 d_albedo, float d_roughness, float d_metallic) {
  const uint32_t mask = uint32_t(table_.size() - 1);
  for (uint32_t s = slot_of(id, shift_);; s = (s + 1) & mask) {
    Entry& x = table_[s];
    if (x.id == id) {
      x.albedo += d_albedo;
      x.roughness += d_roughness;
      x.metallic += d_metallic;
      return;
    }
    if (x.id == kEmpty) {
      x = Entry{id, d_albedo, d_roughness, d_metallic};
      if (2 * ++count_ > table_.size()) grow();  // load factor <= 1/2
      return;
    }
  }
}

void GradientTile::add_mesh(uint32_t mesh, Vec3 d_base_colour, float d_roughness, float d_metallic) {
  mesh_base_colour_[mesh] += d_base_colour;
  mesh_roughness_[mesh] += d_roughness;
  mesh_metallic_[mesh] += d_metallic;
  mesh_touched_ = true;
}

void GradientTile::add_environment(Vec3 d, Vec3 d_Le) {
  if (!env_) return;
  env_touched_ = true;
  if (!env_dense_.empty()) (*env_)->adjoint(d, d_Le, env_dense_.data());
  else env_log_.push_back({d, d_Le});
}

void GradientTile::finish() {
  // The entries move to the front of the table, by id: a finished tile takes no
  // more adds until clear(), which empties every slot.
  size_t n = 0;
  uint32_t max_id = 0;
  for (size_t i = 0; i < table_.size(); ++i)
    if (table_[i].id != kEmpty) {
      max_id = std::max(max_id, table_[i].id);
      table_[n++] = table_[i];
    }
  // LSD radix sort, a byte of the id per pass (ids are unique in a tile: the order
  // is std::sort's), ping-ponging between the entries [0, n) and the free slots
  // [n, 2n) behind them (the load factor is <= 1/2).
  Entry* from = table_.data();
  Entry* to = from + n;
  for (uint32_t shift = 0; shift < 32 && (max_id >> shift) != 0; shift += 8) {
    size_t start[257] = {};
    for (size_t i = 0; i < n; ++i) ++start[((from[i].id >> shift) & 255u) + 1];
    for (int b = 0; b < 256; ++b) start[b + 1] += start[b];
    for (size_t i = 0; i < n; ++i) to[start[(from[i].id >> shift) & 255u]++] = from[i];
    std::swap(from, to);
  }
  if (from != table_.data()) std::copy(from, from + n, table_.data());
}

void GradientTile::add_to(SceneGradients& g) const {
  for (size_t i = 0; i < count_; ++i) {
    const Entry& e = table_[i];
    g.gaussian_albedo[e.id] += e.albedo;
    g.gaussian_roughness[e.id] += e.roughness;
    g.gaussian_metallic[e.id] += e.metallic;
  }
  if (mesh_touched_)
    for (size_t m = 0; m < mesh_base_colour_.size(); ++m) {
      g.mesh_base_colour[m] += mesh_base_colour_[m];
      g.mesh_roughness[m] += mesh_roughness_[m];
      g.mesh_metallic[m] += mesh_metallic_[m];
    }
  if (!env_touched_) return;
  if (!env_dense_.empty())
    for (size_t i = 0; i < env_dense_.size(); ++i) g.environment[i] += env_dense_[i];
  for (const EnvRecord& r : env_log_) (*env_)->adjoint(r.d, r.d_Le, g.environment.data());
}

size_t GradientTile::bytes() const {
  return table_.capacity() * sizeof(Entry) +
         env_dense_.capacity() * sizeof(float) + env_log_.capacity() * sizeof(EnvRecord) +
         mesh_base_colour_.capacity() * sizeof(Vec3) + 2 * mesh_roughness_.capacity() * sizeof(float);
}

}  // namespace ptir
