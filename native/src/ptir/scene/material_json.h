// A mesh's material in a scene file (docs/scene_format.md, "Material"): the
// Principled / Diffuse inputs, each of Base Color, Roughness and Metallic a
// constant or an image texture, and a tangent-space normal map.
#pragma once

#include <string>

#include "ptir/scene/json_node.h"
#include "ptir/scene/mesh.h"
#include "ptir/scene/texture_load.h"

namespace ptir {

// Parses material object n (errors name the file and the JSON path; a texture
// file that cannot be read names it too). Textures load through `cache`.
MeshMaterial parse_material(const json_node::Node& n, const std::string& default_name, TextureCache& cache);

}  // namespace ptir
