#include "ptir/material/ggx_energy.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>

#include "ptir/material/ggx_vndf_quadrature.h"
#include "ptir/material/principled_bsdf.h"
#include "ptir/math/sampling.h"

namespace ptir {

namespace {

constexpr int N = kGgxEnergySize;
constexpr int kStrata = 48;

struct Table {
  std::array<float, N * N> E;  // E[j * N + i]: roughness node j, mu node i
};

float mu_node(int i) { return float(i) / float(N - 1); }  // mu = 0 is evaluated at 1e-4
float r_node(int j) { return float(j) / float(N - 1); }

const Table& table() {
  static Table t;
  static std::once_flag once;
  std::call_once(once, [] {
    tbb::parallel_for(0, N * N, [](int k) {
      const int i = k % N, j = k / N;
      t.E[size_t(k)] = float(ggx_energy_reference(mu_node(i), r_node(j), kStrata));
    });
  });
  return t;
}

}  // namespace

double ggx_energy_reference(float mu_o, float roughness, int strata) {
  const float alpha = roughness * roughness;
  if (!(alpha > 1e-6f)) return 1.0;  // a mirror reflects everything (G1 -> 1)
  const float mu = std::clamp(mu_o, 1e-4f, 1.0f);
  const Vec3 wo(std::sqrt(std::max(0.0f, 1.0f - mu * mu)), 0.0f, mu);
  // Under VNDF sampling eval / pdf = G2 / G1(wo), with 1 / G1(wo) = 1 + Lambda(wo).
  const double lambda_o = smith_lambda(wo, alpha);
  const double G1o_inv = 1.0 + lambda_o;
  return ggx_vndf_quadrature(wo, alpha, strata, [&](Vec3, Vec3 wi, double jacobian) {
    return jacobian * G1o_inv / (1.0 + lambda_o + smith_lambda(wi, alpha));
  });
}

GgxEnergy ggx_energy(float mu_o, float roughness) {
  const Table& t = table();
  // Continuous node coordinates, clamped to the table.
  const float x = std::clamp(mu_o, 0.0f, 1.0f) * float(N - 1);
  const float y = std::clamp(roughness, 0.0f, 1.0f) * float(N - 1);
  const int i0 = std::min(int(x), N - 2), j0 = std::min(int(y), N - 2);
  const float fx = x - float(i0), fy = y - float(j0);
  auto at = [&](int i, int j) { return t.E[size_t(j * N + i)]; };
  const float e0 = at(i0, j0) * (1.0f - fx) + at(i0 + 1, j0) * fx;  // along mu at roughness node j0
  const float e1 = at(i0, j0 + 1) * (1.0f - fx) + at(i0 + 1, j0 + 1) * fx;
  GgxEnergy g;
  g.E = e0 * (1.0f - fy) + e1 * fy;
  g.dE_dr = (roughness >= 0.0f && roughness <= 1.0f) ? (e1 - e0) * float(N - 1) : 0.0f;
  return g;
}

}  // namespace ptir
