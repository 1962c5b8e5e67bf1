// Counter-based random numbers: every value is a pure function of its keys
// (seed, pixel, sample, bounce, dimension, ...), so any path can be replayed
// exactly, on any thread, in any order.
#pragma once

#include <cstdint>

namespace ptir {

// SplitMix64 finaliser: a fast, well-mixed 64-bit hash.
inline uint64_t mix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

inline uint64_t hash_combine(uint64_t a, uint64_t b) { return mix64(a ^ (mix64(b) + 0x632BE59BD9B4E019ull)); }

// Uniform float in [0, 1) from the top 24 bits of a hash.
inline float to_unit_float(uint64_t h) { return float(h >> 40) * (1.0f / 16777216.0f); }

// A stream of uniforms for one (key) — typically key = hash of (seed, pixel, sample).
class Rng {
 public:
  explicit Rng(uint64_t key) : key_(mix64(key)) {}
  Rng(uint64_t a, uint64_t b) : key_(hash_combine(a, b)) {}
  Rng(uint64_t a, uint64_t b, uint64_t c) : key_(hash_combine(hash_combine(a, b), c)) {}
  // The i-th uniform of the stream, independent of how many were drawn before.
  float at(uint64_t i) const { return to_unit_float(mix64(key_ + 0xA0761D6478BD642Full * (i + 1))); }
  // Sequential draws.
  float next() { return at(counter_++); }
  uint64_t key() const { return key_; }

 private:
  uint64_t key_;
  uint64_t counter_ = 0;
};

}  // namespace ptir
