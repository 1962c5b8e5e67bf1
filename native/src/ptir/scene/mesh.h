// Triangle meshes (walls, floors, props) and their materials (Blender Principled or Diffuse BSDF).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "ptir/math/vec.h"
#include "ptir/material/shading_model.h"

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
};

struct TriangleMesh {
  std::string name;
  std::vector<Vec3> vertices;
  std::vector<std::array<uint32_t, 3>> triangles;
  // Per-vertex shading normals (unit; the file's nx, ny, nz), or empty: flat shading.
  // A corner that needs its own normal (a sharp edge, a flat face, Blender's custom
  // split normals) comes as its own vertex.
  std::vector<Vec3> normals;
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
};

// Loads a triangle mesh from .ply (element "vertex" with x,y,z, optionally nx,ny,nz
// (shading normals, normalised; all three or none), and element "face" with a
// vertex_indices/vertex_index list; polygons are fan-triangulated) or .obj
// (v and f lines; polygons fan-triangulated; negative indices allowed; texture and
// normal indices ignored). Throws ptir::Error("<path>: <problem>") on bad input:
// unknown extension, missing properties, index out of range, NaN/Inf vertices,
// zero or non-finite normals, no triangles.
TriangleMesh load_mesh(const std::string& path);

}  // namespace ptir
