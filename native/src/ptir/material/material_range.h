// The range of per-splat material values: albedo (each channel), roughness and
// metallic are Principled BSDF inputs in [0, 1], as Blender's sliders and the
// add-on's material editor give them (the optimiser's sigmoids stay inside).
// A value outside (albedo 1e30, albedo -5, roughness 7, metallic -3) renders
// NaN pixels or light from nowhere, so every reader of per-splat materials
// refuses it with this one rule: the Gaussian PLY reader, on every command
// (scene/gaussian_ply.cpp), and `serve`'s splat_materials.
#pragma once

#include <cstddef>
#include <string>

namespace ptir {

// False for NaN, infinities and anything outside [0, 1].
inline bool material_value_in_range(float value) { return value >= 0.0f && value <= 1.0f; }

// Throws Error(file, "<what> is <value> at Gaussian <index>, outside [0, 1] ...")
// unless material_value_in_range(value). `what` names the property ("albedo_0",
// "roughness").
void check_material_value(float value, const std::string& file, const std::string& what, size_t gaussian);

}  // namespace ptir
