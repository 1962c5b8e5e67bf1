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

}  // namespace ptir
