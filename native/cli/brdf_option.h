// The --brdf option every rendering command shares: which surface model shades
// the scene (material/shading_model.h). Unset: the scene file's "brdf" when it names
// one; else, for a dataset (optimize, eval, relight), the model the dataset records
// ("ptir_brdf" in its transforms_*.json); else principled-v2 (scene/dataset.h
// resolve_bsdf_model). A resumed optimisation keeps its checkpoint's model.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "ptir/pipeline/brdf_choice.h"

namespace ptir::cli {

inline void add_brdf_option(CLI::App* cmd, std::string* value) {
  cmd->add_option("--brdf", *value,
                  "surface model: principled-v2 (Cycles' Principled BSDF of Blender 4.0+, the default), principled-v1 "
                  "(Blender 3.x's; 'principled' is the same) or disney-simplified (the paper's). Default: the scene "
                  "file's \"brdf\", else the dataset's \"ptir_brdf\", else principled-v2");
}

// Applies --brdf when it was given.
inline void apply_brdf_option(const std::string& value, BsdfModel& model) { pipeline::apply_brdf_choice(value, model); }

}  // namespace ptir::cli
