#include "ptir/scene/mesh_surface.h"

#include <algorithm>

namespace ptir {

namespace {

float clamp01(float x) { return std::clamp(x, 0.0f, 1.0f); }

// Cycles' Normal Map node in tangent space (svm_node_normal_map): the texel's
// colour c in [0, 1]^3 becomes 2c - 1 in the frame of the interpolated (not
// normalised) tangent t, bitangent sign * (n x t) and normal n (the smooth
// normal interpolated, else the face's), normalised; mirrored on a back face;
// then blended with the unmapped normal by Strength. Without tangents the
// normal stays unmapped, as Cycles leaves it without its tangent attribute.
Vec3 normal_mapped(const TriangleMesh& mesh, uint32_t prim, float u, float v, Uv uv, bool back_face, Vec3 unmapped) {
  const MeshMaterial& m = mesh.material;
  if (mesh.tangents.empty()) return unmapped;
  const auto& tri = mesh.triangles[prim];
  const float w = 1.0f - u - v;
  const Vec3 t = w * mesh.tangents[tri[0]] + u * mesh.tangents[tri[1]] + v * mesh.tangents[tri[2]];
  const float sign = w * mesh.tangent_signs[tri[0]] + u * mesh.tangent_signs[tri[1]] + v * mesh.tangent_signs[tri[2]];
  const Vec3 n = mesh.smooth() ? w * mesh.normals[tri[0]] + u * mesh.normals[tri[1]] + v * mesh.normals[tri[2]]
                               : mesh.face_normal(prim);
  const Vec3 c = 2.0f * (m.normal_map->rgb(uv) - Vec3(0.5f));
  Vec3 N = normalize(c.x * t + c.y * (sign * cross(n, t)) + c.z * n);
  if (back_face) N = -N;
  if (m.normal_map_strength != 1.0f) N = normalize(unmapped + (N - unmapped) * std::max(m.normal_map_strength, 0.0f));
  return length_sq(N) > 0.0f ? N : unmapped;
}

}  // namespace

MeshSurface mesh_surface(const TriangleMesh& mesh, uint32_t prim, float u, float v, Vec3 d, Vec3 ng) {
  const MeshMaterial& mm = mesh.material;
  MeshSurface s;
  s.material = {mm.base_colour, mm.roughness, mm.metallic, mm.specular, mm.specular_tint,
                mm.ior, mm.specular_ior_level, mm.specular_tint_color, mm.diffuse_roughness};
  // The interpolated normal on the viewer's side of the face.
  s.n = ng;
  if (mesh.smooth()) {
    const Vec3 ns = mesh.shading_normal(prim, u, v);
    s.n = dot(ns, ng) < 0.0f ? -ns : ns;
  }
  s.ns = s.n;
  if (!mm.textured()) return s;
  const Uv uv = mesh.uv_at(prim, u, v);
  // Textures replace the socket's constant (Roughness and Metallic read the colour's luminance, Cycles' conversion).
  if (mm.base_colour_map) s.material.albedo = mesh_base_colour(mesh, prim, u, v);
  if (mm.roughness_map) s.material.roughness = clamp01(luminance(mm.roughness_map->rgb(uv)));
  if (mm.metallic_map) s.material.metallic = clamp01(luminance(mm.metallic_map->rgb(uv)));
  if (mm.normal_map) s.n = normal_mapped(mesh, prim, u, v, uv, dot(mesh.face_normal(prim), d) > 0.0f, s.n);
  return s;
}

Vec3 mesh_base_colour(const TriangleMesh& mesh, uint32_t prim, float u, float v) {
  if (!mesh.material.base_colour_map) return mesh.material.base_colour;
  const Vec3 c = mesh.material.base_colour_map->rgb(mesh.uv_at(prim, u, v));
  return Vec3(clamp01(c.x), clamp01(c.y), clamp01(c.z));
}

}  // namespace ptir
