// Small scenes built in code for the native tests.
#pragma once

#include <cmath>
#include <random>

#include "ptir/scene/gaussians.h"
#include "ptir/scene/mesh.h"

namespace ptir::test {

// Adds one Gaussian with the given activated values and a default material.
inline void add_gaussian(GaussianField& f, Vec3 mu, Vec3 scale, std::array<float, 4> q, float opacity,
                         Vec3 albedo = Vec3(0.3f), float roughness = 0.6f, float metallic = 0.0f) {
  float len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (float& c : q) c /= len;
  f.position.push_back(mu);
  f.scale.push_back(scale);
  f.rotation.push_back(q);
  f.opacity.push_back(opacity);
  f.albedo.push_back(albedo);
  f.roughness.push_back(roughness);
  f.metallic.push_back(metallic);
  Mat3 r = quat_to_mat3(q[0], q[1], q[2], q[3]);
  int k = scale.x <= scale.y && scale.x <= scale.z ? 0 : (scale.y <= scale.z ? 1 : 2);
  f.normal.push_back(r.col(k));
  f.sh.insert(f.sh.end(), {albedo.x, albedo.y, albedo.z});  // degree-0 DC term
}

// n random anisotropic, overlapping Gaussians in the cube [-1, 1]^3.
inline GaussianField random_field(size_t n, uint32_t seed, float min_scale = 0.02f, float max_scale = 0.3f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  GaussianField f;
  for (size_t i = 0; i < n; ++i) {
    Vec3 mu(2 * u(rng) - 1, 2 * u(rng) - 1, 2 * u(rng) - 1);
    Vec3 s(min_scale + (max_scale - min_scale) * u(rng), min_scale + (max_scale - min_scale) * u(rng),
           min_scale + (max_scale - min_scale) * u(rng));
    std::normal_distribution<float> g(0.0f, 1.0f);
    std::array<float, 4> q = {g(rng), g(rng), g(rng), g(rng)};
    float opacity = 0.02f + 0.97f * u(rng);
    add_gaussian(f, mu, s, q, opacity, Vec3(u(rng), u(rng), u(rng)), 0.05f + 0.9f * u(rng), u(rng));
  }
  return f;
}

// Axis-aligned quad (two triangles) in the plane z = z0 spanning [-h, h]^2.
inline TriangleMesh quad_z(float z0, float h) {
  TriangleMesh m;
  m.name = "quad";
  m.vertices = {Vec3(-h, -h, z0), Vec3(h, -h, z0), Vec3(h, h, z0), Vec3(-h, h, z0)};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

}  // namespace ptir::test
