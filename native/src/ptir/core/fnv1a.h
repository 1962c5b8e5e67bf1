// FNV-1a, 64 bit: a stable hash of bytes for file fingerprints and cache keys
// (not for random numbers: see math/rng.h).
#pragma once

#include <cstdint>
#include <string>

namespace ptir {

inline uint64_t fnv1a(const std::string& s) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

}  // namespace ptir
