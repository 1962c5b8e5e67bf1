// Smoothness prior on a learnt lat-long environment: the Dirichlet energy of its
// log radiance over the sphere,
//     E = 1/(4 pi) sum_c  integral |grad log L_c|^2 dOmega,
// discretised on the texel grid with the sphere's metric: a pair of neighbours in
// one row (theta the row's polar angle) is sin(theta) dphi apart, a pair in one
// column dtheta apart, and each difference quotient counts with its cell's solid
// angle sin(theta) dtheta dphi:
//     row pair:    (r_a - r_b)^2 * dtheta / (sin(theta) dphi)
//     column pair: (r_a - r_b)^2 * sin(theta_edge) dphi / dtheta
// (u wraps; nothing crosses the poles). In log space the prior is blind to the
// light's overall scale and colour, and it is a property of the continuous map:
// a finer grid gives the same energy for the same light.
//
// Why (README, method notes): texels that few paths reach -- the lower hemisphere
// that only an object's undersides see -- otherwise keep whatever their rare,
// noisy gradients made of them, and a diffuse albedo absorbs the error.
#pragma once

namespace ptir {

// E for `raw` (log radiance, RGB texels row-major, width x height); when d_raw is
// given, weight x dE/draw is added to it.
double latlong_log_dirichlet(const float* raw, int width, int height, float* d_raw = nullptr, float weight = 1.0f);

// Colour consistency of the light: the solid-angle weighted variance over the
// sphere of each texel's log chromaticity q_c = log L_c - mean_c' log L_c',
//     C = 1/(4 pi) sum_c integral (q_c - qbar_c)^2 dOmega,   qbar_c its mean.
// Blind to the overall brightness, to the brightness's distribution (the sun) and
// to a global tint (white balance, which the albedo's per-channel scale trades
// against anyway); it penalises a light whose colour changes with direction. Why
// (README, method notes): while the albedo is held back (light first) or where
// it is textured, the environment otherwise takes on the colours of the parts of
// the object that its directions light (a bluish lower hemisphere under a bluish
// pedestal), and the albedo comes out with the complementary cast. PTIR pulls
// the light toward grey (2e-4); this variant leaves the white balance free.
double latlong_log_chroma_variance(const float* raw, int width, int height, float* d_raw = nullptr, float weight = 1.0f);

}  // namespace ptir
