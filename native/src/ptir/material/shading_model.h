// Which surface model shades what, as scene data (the models themselves live in
// material/): the scene-wide BSDF model, and the shader each surface asks for.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace ptir {

// The scene-wide choice of model (scene JSON "brdf", dataset "ptir_brdf", CLI --brdf):
//   principled-v1      Cycles' Principled BSDF v1 (Blender 3.x) and Diffuse BSDF; the
//                      name "principled" (files written before v2 existed) means v1
//   principled-v2      Cycles' Principled BSDF v2 (Blender 4.0 and later)
//   disney-simplified  docs/method.md §4's simplified Disney BRDF on every surface (paper parity, ablation)
// The engine's RenderSettings default is v1; files and commands that name no model get
// kDefaultBsdfModel (what the Blender artists use today).
enum class BsdfModel : uint8_t { PrincipledV1, PrincipledV2, DisneySimplified };
constexpr BsdfModel kDefaultBsdfModel = BsdfModel::PrincipledV2;

// What a surface asks for: Blender's Principled BSDF with distribution "GGX" or
// "Multiscatter GGX", or the Diffuse BSDF node.
enum class SurfaceShader : uint8_t { PrincipledGGX, PrincipledMultiGGX, Diffuse };

// Names as written in scene files, PLY headers and on the command line.
const char* to_string(BsdfModel m);  // "principled-v1" | "principled-v2" | "disney-simplified"
std::optional<BsdfModel> parse_bsdf_model(const std::string& name);  // also "principled" (v1)
// The accepted names, for messages: "principled-v1, principled-v2, disney-simplified (principled = v1)".
const char* bsdf_model_names();
const char* to_string(SurfaceShader s);  // "principled" | "principled-multiscatter" | "diffuse"
std::optional<SurfaceShader> parse_surface_shader(const std::string& name);

}  // namespace ptir
