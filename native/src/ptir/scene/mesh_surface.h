// What a ray sees where it hits a mesh: the shading normal (smooth, normal-mapped)
// and the Principled inputs with the material's image textures read at the hit's
// UVs, as Cycles' shader nodes give them to the BSDF.
#pragma once

#include <cstdint>

#include "ptir/material/material_params.h"
#include "ptir/scene/mesh.h"

namespace ptir {

struct MeshSurface {
  // Unit shading normal on the viewer's side as the nodes give it, before the
  // BSDF's reflection correction (transport/shading_normal.h): the face normal
  // (flat), the interpolated normal (smooth), or the normal map's.
  Vec3 n;
  Vec3 ns;  // the surface's own normal (face or interpolated, on the viewer's side): n without the map
  MaterialParams material;
};

// Triangle `prim` of `mesh` at barycentrics (u, v), seen along ray direction d;
// ng is the unit face normal turned toward the viewer (dot(ng, d) <= 0).
MeshSurface mesh_surface(const TriangleMesh& mesh, uint32_t prim, float u, float v, Vec3 d, Vec3 ng);

// The material's Base Color at the point (textured or constant), for AOVs and previews.
Vec3 mesh_base_colour(const TriangleMesh& mesh, uint32_t prim, float u, float v);

}  // namespace ptir
