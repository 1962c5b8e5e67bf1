// The closures of Cycles' Principled BSDF v2 for the opaque dielectric/metal subset
// (Blender 4.x / 5.x; ../shared/docs/PRINCIPLED_V2.md, read against Cycles'
// kernel/svm/closure.h case CLOSURE_BSDF_PRINCIPLED_ID, closure/bsdf_microfacet.h,
// bsdf_util.h, bsdf_oren_nayar.h, bsdf_diffuse.h). One template for the value
// (T = float) and for the material adjoints (T = Dual<5>, dual.h).
//
// With base colour b, metallic m, roughness r (alpha = r^2), IOR, Specular IOR Level L,
// Specular Tint t (colour), Diffuse Roughness sigma, at the view direction wo (mu = n.wo):
//
//   f~ = S(wi) [ w_m F82(wo.h) + w_s Fgs(wo.h) ] + w_d K(wi)
//   S      = D(h) G2 / (4 mu),  G2 = 1 / (1 + Lambda(wo) + Lambda(wi))       (GGX)
//   metal  F82(c) = sat(F0 + (1 - F0)(1 - c)^5 - B c (1 - c)^6),  F0 = min(b, 1),
//          B = [F0 + (1 - F0)(6/7)^5] 7 / (6/7)^6 (1 - min(t, 1))   (0 when t = 1)
//          w_m = m                                                (GGX)
//              = m Dk / E,  Dk = E + Fms (1 - E)                  (Multiscatter GGX)
//   dielectric  eta_s, F0_s: F0_s = F0(IOR), eta_s = IOR; if L != 0.5: F0_s = 2 L F0(IOR),
//          eta_s = eta(F0_s) (1 / that when IOR < 1)
//          Fgs(c) = lerp(F0', 1, sat((Fd(c, eta_s) - F0(eta_s)) / (1 - F0(eta_s)))),
//          F0' = sat(F0_s t);  w_s = (1 - m) [Dk / E];  created only when eta_s != 1
//   diffuse  w_d = max(b, 0) (1 - m) sat(1 - maxc(A_s)),  A_s = [Dk] lerp(F0', 1, s_tab(r, mu, z))
//          (the albedo estimate of the dielectric lobe, z = sqrt|(eta_s - 1)/(eta_s + 1)|;
//          0 when the Fresnel at mu is 0); K = n.wi / pi (Lambert, sigma < 1e-5) or the
//          energy-preserving Oren-Nayar K = n.wi [a + b_on t + M (1 - E_on(n.wi))],
//          M = Ems (1 - E_on(mu)), Ems = (1/pi) rho^2 (E_avg / (1 - E_avg)) / (1 - rho (1 - E_avg)), rho = sat(b)
//   Multiscatter: E = ggx_E(r, mu), E_avg = ggx_Eavg(r), Fms = Fss E_avg / (1 - Fss (1 - E_avg)),
//          Fss = lerp(F0, 1, 1/21) - B / 126 (metal), lerp(F0', 1, sat((Fss_d(eta_s) - F0) / (1 - F0))) (dielectric)
//
// Sample weights (Cycles' closure pick): metal m avg(lerp(F0, 1, s5_tab)) [avg Dk],
// dielectric (1 - m) avg(lerp(F0', 1, s_tab)) [avg Dk], diffuse avg(w_d) -- with the base
// colour b replaced by a nominal kNominalBaseColour grey (as v1 does), so that the albedo
// changes no sampling decision: path replay holds sampling fixed, and the albedo gradient
// then equals the difference quotient of the estimator exactly.
//
// Departures from Cycles, all below the noise of a render: the metal lobe exists for
// every m (Cycles drops it below m = 1e-5, which would zero the metallic gradient at
// m = 0); roughness is clamped to kPrincipledMinRoughness (Cycles' mirror below
// r = 0.004 needs delta BSDFs, which PTIR's transport does not have); shading normals
// are not bent toward the viewer (Cycles' ensure_valid_specular_reflection).
#pragma once

#include <array>
#include <cmath>

#include "ptir/material/cycles_tables.h"
#include "ptir/material/dual.h"
#include "ptir/material/material_params.h"
#include "ptir/math/sampling.h"
#include "ptir/math/vec.h"

namespace ptir {

// Smallest closure weight Cycles creates, and the Diffuse Roughness below which it is Lambert.
constexpr float kClosureWeightCutoff = 1e-5f;
// The base colour the lobe pick assumes (sample weights only; see below).
constexpr float kNominalBaseColour = 0.5f;

// The dielectric remap of IOR by Specular IOR Level (closure.h "Apply IOR adjustment").
struct SpecularIor {
  float eta = 1.5f;  // IOR of the specular lobe (1: no lobe)
  float F0 = 0.04f;  // its reflectance at normal incidence before the tint
};
SpecularIor specular_ior(float ior, float level);

// Kulla-Conty fit of the average dielectric Fresnel (bsdf_util.h fresnel_dielectric_Fss).
float fresnel_dielectric_Fss(float eta);
// Energy-preserving Oren-Nayar's G(mu) (bsdf_oren_nayar.h): E_on(mu) = a pi + b G(mu).
float oren_nayar_G(float mu);

// F82-tint Fresnel (bsdf_util.h fresnel_f82): F0 + (1 - F0)(1 - c)^5 - B c (1 - c)^6, saturated.
template <class T>
T fresnel_f82(float c, const T& F0, const T& B) {
  const float s = std::clamp(1.0f - c, 0.0f, 1.0f);
  const float s5 = (s * s) * (s * s) * s;
  return saturate_t(F0 + (1.0f - F0) * s5 - B * (c * s5 * s));
}
// Its B for edge tint t (bsdf_util.h fresnel_f82tint_B).
template <class T>
T fresnel_f82tint_B(const T& F0, float tint) {
  constexpr float f = 6.0f / 7.0f;
  const float f5 = (f * f) * (f * f) * f;
  return (F0 + (1.0f - F0) * f5) * ((7.0f / (f5 * f)) * (1.0f - tint));
}

namespace principled_v2_detail {

template <class T>
using Rgb = std::array<T, 3>;

template <class T>
T avg(const Rgb<T>& c) {
  return (c[0] + c[1] + c[2]) * (1.0f / 3.0f);
}

// The parameters that carry derivatives: base colour, roughness, metallic.
template <class T>
struct Inputs {
  Rgb<T> base;
  T roughness, metallic;
};

// Everything of the closures that depends on the vertex (parameters and wo) only.
template <class T>
struct Vertex {
  bool above = false;  // n.wo > 0
  float mu = 1.0f;
  T alpha = T(0.25f), lambda_o = T(0.0f);
  Rgb<T> w_metal{}, F0_metal{}, B_metal{};  // metal lobe: weight (with energy terms), F82 inputs
  bool has_dielectric = false;
  float eta = 1.5f, F0_real = 0.04f;        // dielectric lobe: eta_s, F0(eta_s)
  Rgb<float> F0_tinted{};                   // F0'
  Rgb<T> w_dielectric{};
  Rgb<T> w_diffuse{};
  bool oren_nayar = false;
  float on_a = 0.0f, on_b = 0.0f;           // Oren-Nayar a, b
  Rgb<T> on_ms{};                           // M = Ems (1 - E_on(mu))
  float sw_specular = 0.0f, sw_diffuse = 0.0f;  // pick weights (metal + dielectric, diffuse), nominal base
};

template <class T>
T lambda_ggx(Vec3 w, const T& alpha) {
  const float c2 = w.z * w.z;
  if (!(c2 > 0.0f)) return T(0.0f);
  const float tan2 = std::max(0.0f, 1.0f - c2) / c2;
  return 0.5f * (dual_sqrt(1.0f + alpha * alpha * tan2) - 1.0f);
}

template <class T>
T ggx_D_t(Vec3 h, const T& alpha) {
  if (!(h.z > 0.0f)) return T(0.0f);
  const T a2 = alpha * alpha;
  const T d = (h.x * h.x + h.y * h.y) + a2 * (h.z * h.z);
  return a2 / (kPi * d * d);
}

template <class T>
Vertex<T> prepare(const Inputs<T>& in, const MaterialParams& p, Vec3 wo, bool multiscatter);
template <class T>
Rgb<T> evaluate(const Vertex<T>& v, Vec3 wo, Vec3 wi);
// The diffuse base's part of evaluate.
template <class T>
Rgb<T> evaluate_diffuse(const Vertex<T>& v, Vec3 wo, Vec3 wi);

}  // namespace principled_v2_detail
}  // namespace ptir
