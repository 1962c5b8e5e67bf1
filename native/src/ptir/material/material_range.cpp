#include "ptir/material/material_range.h"

#include <cstdio>

#include "ptir/core/error.h"

namespace ptir {

void check_material_value(float value, const std::string& file, const std::string& what, size_t gaussian) {
  if (material_value_in_range(value)) return;
  char v[32];
  std::snprintf(v, sizeof v, "%g", double(value));
  throw Error(file, "'" + what + "' is " + v + " at Gaussian " + std::to_string(gaussian) +
                        ", outside [0, 1] (albedo, roughness and metallic are Principled BSDF inputs in [0, 1])");
}

}  // namespace ptir
