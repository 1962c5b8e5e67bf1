// Which surface model shades what, as scene data (the models themselves live in
// material/): the scene-wide BSDF model, and the shader each surface asks for.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace ptir {

// The scene-wide choice of model (scene JSON "brdf", CLI --brdf):
//   principled         Cycles' Principled BSDF v1 and Diffuse BSDF (default: what Blender renders)
//   disney-simplified  METHOD §4's simplified Disney BRDF on every surface (paper parity, ablation)
enum class BsdfModel : uint8_t { Principled, DisneySimplified };

// What a surface asks for: Blender's Principled BSDF with distribution "GGX" or
// "Multiscatter GGX", or the Diffuse BSDF node.
enum class SurfaceShader : uint8_t { PrincipledGGX, PrincipledMultiGGX, Diffuse };

// Names as written in scene files, PLY headers and on the command line.
const char* to_string(BsdfModel m);  // "principled" | "disney-simplified"
std::optional<BsdfModel> parse_bsdf_model(const std::string& name);
const char* to_string(SurfaceShader s);  // "principled" | "principled-multiscatter" | "diffuse"
std::optional<SurfaceShader> parse_surface_shader(const std::string& name);

}  // namespace ptir
