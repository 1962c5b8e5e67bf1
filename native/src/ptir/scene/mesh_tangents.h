// Tangents of a mesh's UV map for meshes that come without them (an OBJ, a PLY
// or an inline mesh with UVs but no tx, ty, tz, tw) and carry a normal map.
#pragma once

#include "ptir/scene/mesh.h"

namespace ptir {

// Fills mesh.tangents / tangent_signs from its UVs: per vertex, the sum of its
// triangles' dP/du (area-weighted by the UV parametrisation) made orthogonal to
// the vertex normal (the smooth normal, else the sum of the face normals), and
// the sign of dP/dv against n x t. For a mesh whose UVs are continuous across its
// vertices this is close to MikkTSpace; Blender's own tangents (the add-on writes
// them) are used when the file has them. No-op without UVs.
void compute_tangents(TriangleMesh& mesh);

// Gives a mesh whose material has a normal map the tangents it lacks.
inline void prepare_mesh_tangents(TriangleMesh& mesh) {
  if (mesh.material.normal_map && mesh.tangents.empty()) compute_tangents(mesh);
}

}  // namespace ptir
