// A ray o + t d with its valid parameter range [tmin, tmax]; d is unit length.
#pragma once

#include <limits>

#include "ptir/math/vec.h"

namespace ptir {

struct Ray {
  Vec3 o;
  Vec3 d;
  float tmin = 0.0f;
  float tmax = std::numeric_limits<float>::infinity();
  Vec3 at(float t) const { return o + d * t; }
};

}  // namespace ptir
