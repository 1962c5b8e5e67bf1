// Directional albedo of single-scattering GGX with the height-correlated Smith G
// (as the single-scattering part of Cycles' Multiscatter GGX) and F = 1:
//
//   E(mu_o, r) = int_{H+} D(h) G2(wo, wi) / (4 mu_o) dwi,   G2 = 1 / (1 + Lambda(wo) + Lambda(wi)),
//   alpha = r^2,  mu_o = n.wo
//
// used by the multiple-scattering energy compensation of the Principled BSDF's
// "Multiscatter GGX" distribution (Turquin 2019, "Practical multiple scattering
// compensation for microfacet models"): f_ms = f_ss (1 + F0 (1 - E) / E).
//
// The table (kGgxEnergySize^2 nodes, mu_o in [0, 1] at i / (N - 1), roughness
// r in [0, 1] at j / (N - 1)) is computed once, at first
// use, by stratified visible-normal sampling (48 x 48 strata per node, warped toward the NDF tail; the
// estimator of E under VNDF sampling is G2 / G1(wo), so every sample is cheap and
// bounded by 1). Lookups interpolate bilinearly. Measured error against adaptive quadrature: see test_principled.cpp.
#pragma once

namespace ptir {

constexpr int kGgxEnergySize = 32;

struct GgxEnergy {
  float E = 1.0f;      // directional albedo
  float dE_dr = 0.0f;  // slope of the interpolant along roughness (for gradients)
};

GgxEnergy ggx_energy(float mu_o, float roughness);

// The same quantity by sampling, for one (mu_o, r): what a table node holds.
double ggx_energy_reference(float mu_o, float roughness, int strata);

}  // namespace ptir
