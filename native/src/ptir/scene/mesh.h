// Triangle meshes (walls, floors, props) and their materials (Blender Principled or Diffuse BSDF).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "ptir/math/vec.h"
#include "ptir/material/shading_model.h"
#include "ptir/material/texture.h"

namespace ptir {

struct MeshMaterial {
  std::string name = "default";
  SurfaceShader shader = SurfaceShader::PrincipledGGX;  // Blender node: Principled (GGX / Multiscatter GGX) or Diffuse
  Vec3 base_colour{0.8f, 0.8f, 0.8f};  // linear RGB
  float roughness = 0.5f;               // Diffuse BSDF: its Oren-Nayar sigma
  float metallic = 0.0f;
  float specular = 0.5f;                // Principled Specular (fixed input)
  float specular_tint = 0.0f;           // Principled Specular Tint (fixed input)
  // Principled v2 (Blender 4.0+) inputs, fixed; v1 reads specular / specular_tint instead.
  float ior = 1.5f;                     // IOR
  float specular_ior_level = 0.5f;      // Specular IOR Level
  Vec3 specular_tint_color{1.0f, 1.0f, 1.0f};  // Specular Tint (colour)
  float diffuse_roughness = 0.0f;       // Diffuse Roughness
  Vec3 emission{0.0f, 0.0f, 0.0f};  // emitted radiance (W/m^2/sr), zero for non-emitters
  // Image textures (Blender's Image Texture node on the socket, read at the mesh's
  // UVs; scene/mesh_surface.h), each replacing its constant above where set.
  std::shared_ptr<const Texture> base_colour_map;  // Base Color
  std::shared_ptr<const Texture> roughness_map;    // Roughness (the colour's luminance)
  std::shared_ptr<const Texture> metallic_map;     // Metallic (the colour's luminance)
  std::shared_ptr<const Texture> normal_map;       // Normal Map node (tangent space) into Normal
  float normal_map_strength = 1.0f;                // the Normal Map node's Strength
  bool textured() const { return base_colour_map || roughness_map || metallic_map || normal_map; }
};

struct TriangleMesh {
  std::string name;
  std::vector<Vec3> vertices;
  std::vector<std::array<uint32_t, 3>> triangles;
  // Per-vertex shading normals (unit; the file's nx, ny, nz), or empty: flat shading.
  // A corner that needs its own normal (a sharp edge, a flat face, Blender's custom
  // split normals) comes as its own vertex.
  std::vector<Vec3> normals;
  // Per-vertex texture coordinates (the UV map the textures use), or empty: every
  // point reads uv (0, 0), as Cycles does without the map. A corner with its own
  // UV (a seam) comes as its own vertex.
  std::vector<Uv> uvs;
  // Per-vertex tangents of that UV map (MikkTSpace, as Blender computes them: unit
  // tangent and the bitangent's sign, B = sign n x t), or empty (then computed from
  // the UVs when a normal map needs them: mesh_tangents.h).
  std::vector<Vec3> tangents;
  std::vector<float> tangent_signs;
  MeshMaterial material;

  // Unit geometric normal of triangle `prim` (right-handed winding).
  Vec3 face_normal(uint32_t prim) const {
    const auto& tri = triangles[prim];
    return normalize(cross(vertices[tri[1]] - vertices[tri[0]], vertices[tri[2]] - vertices[tri[0]]));
  }
  bool smooth() const { return !normals.empty(); }
  // Unit shading normal at barycentrics (u, v) of triangle `prim` (the weights of
  // its second and third corners, as Embree reports them): the corners' normals
  // interpolated, or the face normal without normals (or where they cancel).
  Vec3 shading_normal(uint32_t prim, float u, float v) const {
    if (normals.empty()) return face_normal(prim);
    const auto& tri = triangles[prim];
    const Vec3 n = normalize((1.0f - u - v) * normals[tri[0]] + u * normals[tri[1]] + v * normals[tri[2]]);
    return length_sq(n) > 0.0f ? n : face_normal(prim);
  }
  // Texture coordinates at barycentrics (u, v) of triangle `prim`.
  Uv uv_at(uint32_t prim, float u, float v) const {
    if (uvs.empty()) return {};
    const auto& tri = triangles[prim];
    const float w = 1.0f - u - v;
    return {w * uvs[tri[0]].u + u * uvs[tri[1]].u + v * uvs[tri[2]].u,
            w * uvs[tri[0]].v + u * uvs[tri[1]].v + v * uvs[tri[2]].v};
  }
};

// Loads a triangle mesh from .ply (element "vertex" with x,y,z, optionally nx,ny,nz
// (shading normals, normalised; all three or none), s,t (or u,v: texture
// coordinates), tx,ty,tz,tw (tangent and bitangent sign), and element "face" with a
// vertex_indices/vertex_index list; polygons are fan-triangulated) or .obj
// (v and f lines; polygons fan-triangulated; negative indices allowed; texture and
// normal indices ignored). Throws ptir::Error("<path>: <problem>") on bad input:
// unknown extension, missing properties, index out of range, NaN/Inf vertices,
// zero or non-finite normals, no triangles.
TriangleMesh load_mesh(const std::string& path);

}  // namespace ptir
