#include "ptir/scene/mesh_tangents.h"

namespace ptir {

void compute_tangents(TriangleMesh& mesh) {
  if (mesh.uvs.empty()) return;
  const size_t n = mesh.vertices.size();
  std::vector<Vec3> dpdu(n), dpdv(n), normal_sum(n);
  for (const auto& tri : mesh.triangles) {
    const Vec3 e1 = mesh.vertices[tri[1]] - mesh.vertices[tri[0]], e2 = mesh.vertices[tri[2]] - mesh.vertices[tri[0]];
    const float du1 = mesh.uvs[tri[1]].u - mesh.uvs[tri[0]].u, dv1 = mesh.uvs[tri[1]].v - mesh.uvs[tri[0]].v;
    const float du2 = mesh.uvs[tri[2]].u - mesh.uvs[tri[0]].u, dv2 = mesh.uvs[tri[2]].v - mesh.uvs[tri[0]].v;
    const Vec3 area_normal = cross(e1, e2);
    // (e1 e2) = (dP/du dP/dv) (du1 du2; dv1 dv2): solved times the UV determinant,
    // whose sign is kept (a mirrored UV island flips it) and whose size weights by UV area.
    const float det = du1 * dv2 - du2 * dv1;
    const Vec3 tu = (dv2 * e1 - dv1 * e2) * (det < 0.0f ? -1.0f : 1.0f);
    const Vec3 tv = (du1 * e2 - du2 * e1) * (det < 0.0f ? -1.0f : 1.0f);
    for (uint32_t k : tri) {
      dpdu[k] = dpdu[k] + tu;
      dpdv[k] = dpdv[k] + tv;
      normal_sum[k] = normal_sum[k] + area_normal;
    }
  }
  mesh.tangents.assign(n, Vec3(0.0f));
  mesh.tangent_signs.assign(n, 1.0f);
  for (size_t i = 0; i < n; ++i) {
    const Vec3 nv = mesh.normals.empty() ? normalize(normal_sum[i]) : mesh.normals[i];
    const Vec3 t = dpdu[i] - dot(dpdu[i], nv) * nv;  // Gram-Schmidt against the normal
    if (!(length_sq(t) > 0.0f) || !is_finite(t)) continue;
    mesh.tangents[i] = normalize(t);
    mesh.tangent_signs[i] = dot(cross(nv, mesh.tangents[i]), dpdv[i]) < 0.0f ? -1.0f : 1.0f;
  }
}

}  // namespace ptir
