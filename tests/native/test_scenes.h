// Small scenes built in code for the native tests.
#pragma once

#include <cmath>
#include <random>

#include "ptir/io/image.h"
#include "ptir/scene/gaussians.h"
#include "ptir/scene/mesh.h"

namespace ptir::test {

// Mean of the centre block of pixels (radius r) of channel c.
inline double centre_mean(const Image& img, int c, int r) {
  double s = 0;
  int n = 0;
  for (int y = img.height / 2 - r; y <= img.height / 2 + r; ++y)
    for (int x = img.width / 2 - r; x <= img.width / 2 + r; ++x, ++n) s += img.at(x, y, c);
  return s / n;
}

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

// Unit quaternion (w, x, y, z) of the rotation whose columns are s, t, n.
inline std::array<float, 4> quat_from_frame(const Frame& f) {
  Mat3 m = Mat3::from_cols(f.s, f.t, f.n);
  float tr = m.m[0][0] + m.m[1][1] + m.m[2][2];
  if (tr > 0) {
    float S = std::sqrt(tr + 1) * 2;
    return {0.25f * S, (m.m[2][1] - m.m[1][2]) / S, (m.m[0][2] - m.m[2][0]) / S, (m.m[1][0] - m.m[0][1]) / S};
  }
  if (m.m[0][0] > m.m[1][1] && m.m[0][0] > m.m[2][2]) {
    float S = std::sqrt(1 + m.m[0][0] - m.m[1][1] - m.m[2][2]) * 2;
    return {(m.m[2][1] - m.m[1][2]) / S, 0.25f * S, (m.m[0][1] + m.m[1][0]) / S, (m.m[0][2] + m.m[2][0]) / S};
  }
  if (m.m[1][1] > m.m[2][2]) {
    float S = std::sqrt(1 + m.m[1][1] - m.m[0][0] - m.m[2][2]) * 2;
    return {(m.m[0][2] - m.m[2][0]) / S, (m.m[0][1] + m.m[1][0]) / S, 0.25f * S, (m.m[1][2] + m.m[2][1]) / S};
  }
  float S = std::sqrt(1 + m.m[2][2] - m.m[0][0] - m.m[1][1]) * 2;
  return {(m.m[1][0] - m.m[0][1]) / S, (m.m[0][2] + m.m[2][0]) / S, (m.m[1][2] + m.m[2][1]) / S, 0.25f * S};
}

// A closed sphere surface of n flat, overlapping, nearly opaque Gaussians (a
// Fibonacci lattice), normals pointing out.
inline GaussianField gaussian_sphere(size_t n, float radius, Vec3 albedo, float roughness, float metallic,
                                     float opacity = 0.99f) {
  GaussianField f;
  float spacing = radius * std::sqrt(4.0f * kPi / float(n));
  for (size_t i = 0; i < n; ++i) {
    float z = 1 - 2 * (i + 0.5f) / float(n), r = std::sqrt(std::max(0.0f, 1 - z * z)), phi = float(i) * 2.39996323f;
    Vec3 nrm(r * std::cos(phi), r * std::sin(phi), z);
    Frame fr(nrm);
    add_gaussian(f, nrm * radius, Vec3(0.7f * spacing, 0.7f * spacing, 1e-3f * spacing), quat_from_frame(fr), opacity,
                 albedo, roughness, metallic);
    f.normal.back() = nrm;
  }
  f.normals_from_file = true;
  return f;
}

}  // namespace ptir::test
