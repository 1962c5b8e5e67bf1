// The --brdf option every rendering command shares: which surface model shades
// the scene (scene/shading_model.h). Unset, the scene file's "brdf" (default
// "principled") stands.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "ptir/core/error.h"
#include "ptir/material/shading_model.h"

namespace ptir::cli {

inline void add_brdf_option(CLI::App* cmd, std::string* value) {
  cmd->add_option("--brdf", *value,
                  "surface model: principled (Cycles' Principled BSDF v1, default) or disney-simplified (the paper's)");
}

// Applies --brdf when it was given.
inline void apply_brdf_option(const std::string& value, BsdfModel& model) {
  if (value.empty()) return;
  auto m = parse_bsdf_model(value);
  if (!m) throw Error("--brdf must be 'principled' or 'disney-simplified', got '" + value + "'");
  model = *m;
}

}  // namespace ptir::cli
