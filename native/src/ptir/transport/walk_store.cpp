#include "ptir/transport/walk_store.h"

#include <algorithm>
#include <cstring>

namespace ptir {

namespace {

uint32_t float_bits(float x) {
  uint32_t u;
  std::memcpy(&u, &x, sizeof u);
  return u;
}

float bits_float(uint32_t u) {
  float x;
  std::memcpy(&x, &u, sizeof x);
  return x;
}

}  // namespace

void PathWalkWriter::add(const GaussianHit* hits, size_t n, const WalkEnd& end, bool escaped) {
  if (escaped) {  // the replay needs only the fact (its direction it has)
    words.push_back(kWalkEscaped);
    return;
  }
  const bool mesh = end.mesh.valid;
  n = std::min<size_t>(n, kWalkCountMask);
  const size_t at = words.size();
  words.resize(at + 1 + 3 * n + (mesh ? 5 : 0));
  uint32_t* w = words.data() + at;
  *w++ = uint32_t(n) | (end.stopped ? kWalkStopped : 0u) | (mesh ? kWalkMesh : 0u);
  static_assert(sizeof(GaussianHit) == 3 * sizeof(uint32_t), "a hit is three words: t, alpha, id");
  std::memcpy(w, hits, n * sizeof(GaussianHit));
  w += 3 * n;
  if (mesh) {
    w[0] = float_bits(end.mesh.t);
    w[1] = end.mesh.mesh;
    w[2] = end.mesh.prim;
    w[3] = float_bits(end.mesh.u);
    w[4] = float_bits(end.mesh.v);
  }
}

void PathWalkWriter::add_light(bool contributed, Vec3 wi, Vec3 Li, float weight) {
  if (!contributed) {
    words.push_back(0u);
    return;
  }
  const uint32_t w[8] = {1u,          float_bits(wi.x), float_bits(wi.y), float_bits(wi.z),
                         float_bits(Li.x), float_bits(Li.y), float_bits(Li.z), float_bits(weight)};
  words.insert(words.end(), w, w + 8);
}

bool PathWalkReader::next_light(Vec3* wi, Vec3* Li, float* weight) {
  if (*at_++ == 0u) return false;
  *wi = Vec3(bits_float(at_[0]), bits_float(at_[1]), bits_float(at_[2]));
  *Li = Vec3(bits_float(at_[3]), bits_float(at_[4]), bits_float(at_[5]));
  *weight = bits_float(at_[6]);
  at_ += 7;
  return true;
}

void PathWalkWriter::add_bsdf(const BsdfSample& bs) {
  if (!bs.valid) {
    words.push_back(0u);
    return;
  }
  const uint32_t w[8] = {1u,
                         float_bits(bs.wi.x),     float_bits(bs.wi.y),     float_bits(bs.wi.z),
                         float_bits(bs.weight.x), float_bits(bs.weight.y), float_bits(bs.weight.z),
                         float_bits(bs.pdf)};
  words.insert(words.end(), w, w + 8);
}

BsdfSample PathWalkReader::next_bsdf() {
  BsdfSample bs;
  if (*at_++ == 0u) return bs;
  bs.wi = Vec3(bits_float(at_[0]), bits_float(at_[1]), bits_float(at_[2]));
  bs.weight = Vec3(bits_float(at_[3]), bits_float(at_[4]), bits_float(at_[5]));
  bs.pdf = bits_float(at_[6]);
  bs.valid = true;
  at_ += 7;
  return bs;
}

bool PathWalkReader::next(std::vector<GaussianHit>* hits, WalkEnd* end) {
  const uint32_t header = *at_++;
  hits->clear();
  *end = WalkEnd();
  if (header & kWalkEscaped) return false;
  const uint32_t n = header & kWalkCountMask;
  hits->resize(n);
  std::memcpy(hits->data(), at_, n * sizeof(GaussianHit));  // t, alpha, id (as written)
  at_ += 3 * n;
  end->stopped = (header & kWalkStopped) != 0;
  if (header & kWalkMesh) {
    end->mesh.valid = true;
    end->mesh.t = bits_float(at_[0]);
    end->mesh.mesh = at_[1];
    end->mesh.prim = at_[2];
    end->mesh.u = bits_float(at_[3]);
    end->mesh.v = bits_float(at_[4]);
    at_ += 5;
  }
  return true;
}

size_t WalkStore::kept() const {
  return size_t(std::count_if(slots_.begin(), slots_.end(), [](const uint32_t* p) { return p != nullptr; }));
}

void WalkStore::reset(size_t samples) {
  slots_.assign(samples, nullptr);
  cursors_.clear();
  // The chunks stay allocated for the next render (no fresh pages to fault in).
  for (auto& c : chunks_) spare_.push_back(std::move(c));
  chunks_.clear();
  while (!spare_.empty() && spare_.size() * chunk_words_ > budget_words_) spare_.pop_back();
  used_words_ = 0;
  full_ = false;
}

uint32_t* WalkStore::claim(size_t words) {
  if (words > chunk_words_) return nullptr;
  Cursor& c = cursors_.local();
  if (c.left < words) {
    // A new chunk for this thread (the rest of the old one stays unused).
    if (full_.load(std::memory_order_relaxed)) return nullptr;
    std::lock_guard<std::mutex> lock(mutex_);
    if (used_words_.load() + chunk_words_ > budget_words_) {
      full_ = true;  // no more locking for the rest of this render
      return nullptr;
    }
    if (!spare_.empty()) {
      chunks_.push_back(std::move(spare_.back()));
      spare_.pop_back();
    } else {
      chunks_.emplace_back(new uint32_t[chunk_words_]);  // uninitialised: every word used is written
    }
    used_words_ += chunk_words_;
    c.at = chunks_.back().get();
    c.left = chunk_words_;
  }
  uint32_t* at = c.at;
  c.at += words;
  c.left -= words;
  return at;
}

void WalkStore::keep(size_t i, const PathWalkWriter& path) {
  if (i >= slots_.size() || path.words.empty()) return;
  uint32_t* at = claim(path.words.size());
  if (!at) return;
  std::memcpy(at, path.words.data(), path.words.size() * sizeof(uint32_t));
  slots_[i] = at;
}

}  // namespace ptir
