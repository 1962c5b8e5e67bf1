// The surface model a run asks for by name (--brdf; material/shading_model.h),
// over the one the scene, the dataset or a checkpoint records.
#pragma once

#include <string>

#include "ptir/core/error.h"
#include "ptir/material/shading_model.h"

namespace ptir::pipeline {

// Applies `name` when it is given (non-empty); throws Error naming --brdf for an unknown one.
inline void apply_brdf_choice(const std::string& name, BsdfModel& model) {
  if (name.empty()) return;
  auto m = parse_bsdf_model(name);
  if (!m) throw Error(std::string("--brdf must be one of ") + bsdf_model_names() + ", got '" + name + "'");
  model = *m;
}

}  // namespace ptir::pipeline
