#include "ptir/scene/material_json.h"


namespace ptir {

using json_node::Node;

namespace {

// {"texture": path, "colorspace": "srgb" | "non-color", "interpolation": "linear" |
// "closest", "extension": "repeat"}: Blender's Image Texture node with its UV map.
std::shared_ptr<const Texture> parse_texture(const Node& n, const char* default_space, TextureCache& cache) {
  n.check_keys({"texture", "colorspace", "interpolation", "extension"});
  n.require("texture");
  const std::string path = n.file("texture");
  const bool srgb = n.choice("colorspace", default_space, {"srgb", "non-color"}) == "srgb";
  const bool linear = n.choice("interpolation", "linear", {"linear", "closest"}) == "linear";
  n.choice("extension", "repeat", {"repeat"});
  return json_node::with_context(n["texture"], [&] {
    return cache.get(path, srgb ? TextureColourSpace::Srgb : TextureColourSpace::NonColor,
                     linear ? TextureInterpolation::Linear : TextureInterpolation::Closest);
  });
}

// A float input: a number in [0, 1] or a texture (Non-Color by default: data).
void parse_scalar_input(const Node& n, const char* key, float& value, std::shared_ptr<const Texture>& map,
                        TextureCache& cache) {
  if (n.has(key) && n[key].j.is_object())
    map = parse_texture(n[key], "non-color", cache);
  else
    value = n.number_in(key, value, 0.0f, 1.0f);
}

}  // namespace

MeshMaterial parse_material(const Node& n, const std::string& default_name, TextureCache& cache) {
  n.check_keys({"name", "shader", "base_color", "roughness", "metallic", "specular", "specular_tint", "ior",
                "specular_ior_level", "specular_tint_color", "diffuse_roughness", "emission", "normal_map"});
  MeshMaterial m;
  m.name = n.string("name", default_name);
  m.shader = *parse_surface_shader(n.choice("shader", "principled", {"principled", "principled-multiscatter", "diffuse"}));
  if (n.has("base_color") && n["base_color"].j.is_object()) {
    m.base_colour_map = parse_texture(n["base_color"], "srgb", cache);
  } else if (n.has("base_color")) {
    Node c = n["base_color"];
    m.base_colour = c.vec3();
    for (int k = 0; k < 3; ++k)
      if (m.base_colour[k] < 0.0f || m.base_colour[k] > 1.0f) c.fail("components must be in [0, 1] (linear RGB)");
  }
  parse_scalar_input(n, "roughness", m.roughness, m.roughness_map, cache);
  parse_scalar_input(n, "metallic", m.metallic, m.metallic_map, cache);
  m.specular = n.number_in("specular", m.specular, 0.0f, 12.0f);  // 12.5 would be an infinite IOR
  m.specular_tint = n.number_in("specular_tint", m.specular_tint, 0.0f, 1.0f);
  // Principled v2 (docs/scene_format.md: which model reads which field).
  m.ior = n.number_in("ior", m.ior, 1e-3f, 1000.0f);
  m.specular_ior_level = n.number_in("specular_ior_level", m.specular_ior_level, 0.0f, 1.0f);
  if (n.has("specular_tint_color")) {
    Node c = n["specular_tint_color"];
    m.specular_tint_color = c.vec3();
    for (int k = 0; k < 3; ++k)
      if (!(m.specular_tint_color[k] >= 0.0f && m.specular_tint_color[k] <= 1.0f)) c.fail("components must be in [0, 1] (linear RGB)");
  }
  m.diffuse_roughness = n.number_in("diffuse_roughness", m.diffuse_roughness, 0.0f, 1.0f);
  m.emission = n.colour("emission", m.emission);
  if (n.has("normal_map")) {
    // {"texture": ..., "strength": s (default 1), ...}: a Normal Map node (tangent space) into Normal.
    Node nm = n["normal_map"];
    nm.expect_object();
    json_node::json rest = nm.j;
    rest.erase("strength");
    m.normal_map = parse_texture(Node{rest, nm.path, nm.ctx}, "non-color", cache);
    m.normal_map_strength = nm.number_in("strength", 1.0f, 0.0f, 100.0f);
  }
  return m;
}

}  // namespace ptir
