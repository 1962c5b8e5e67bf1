// Stratified quadrature over GGX's visible normals: the one integration loop
// behind the GGX albedo tables (ggx_energy.cpp, the Principled BSDF's multiscatter
// compensation) and Cycles' v2 lookup tables (cycles_tables.cpp).
//
// For wo in the local frame and roughness alpha, it averages g(h, wi) x (the
// midpoint rule's weight) over visible normals h drawn by sample_ggx_vndf and
// their reflections wi = reflect(wo, h); samples reflected below the horizon add
// nothing. Midpoint rule in (v, u2) with u1 = 1 - (1 - v)^3 (Jacobian 3 (1 - v)^2):
// the warp puts strata into the NDF's tail (u1 -> 1, grazing h), where G1(wi) < 1
// comes from and the integrands vary fastest; a plain midpoint rule in u1 misses
// it at low roughness.
#pragma once

#include "ptir/math/sampling.h"
#include "ptir/math/vec.h"

namespace ptir {

// (1 / strata^2) sum over strata^2 visible normals of term(h, wi, jacobian), where
// term returns the integrand times `jacobian` (3 (1 - v)^2, passed in so that each
// caller keeps its own order of operations).
template <class Term>
double ggx_vndf_quadrature(Vec3 wo, float alpha, int strata, Term&& term) {
  double sum = 0.0;
  for (int a = 0; a < strata; ++a)
    for (int b = 0; b < strata; ++b) {
      const double v = (a + 0.5) / strata, w = 1.0 - v;
      const float u1 = float(1.0 - w * w * w), u2 = (float(b) + 0.5f) / float(strata);
      const Vec3 h = sample_ggx_vndf(wo, alpha, u1, u2);
      const Vec3 wi = reflect(wo, h);
      if (wi.z > 0.0f) sum += term(h, wi, 3.0 * w * w);
    }
  return sum / (double(strata) * strata);
}

}  // namespace ptir
