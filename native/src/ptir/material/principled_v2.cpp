// Principled BSDF v2: the closures of principled_v2_lobes.h (one template for
// values and dual-number gradients) and the BSDF of principled_v2.h.
#include "ptir/material/principled_v2.h"

#include <algorithm>
#include <cfloat>
#include <cmath>

namespace ptir {

SpecularIor specular_ior(float ior, float level) {
  const float ior_c = std::max(ior, 1e-5f), level_c = std::max(level, 0.0f);
  SpecularIor s{ior_c, F0_from_ior(ior_c)};
  if (level_c != 0.5f) {  // exact comparison, as Cycles
    s.F0 *= 2.0f * level_c;
    s.eta = ior_from_F0(s.F0);
    if (ior_c < 1.0f) s.eta = 1.0f / s.eta;
  }
  return s;
}

float fresnel_dielectric_Fss(float eta) {
  if (eta < 1.0f) return 0.997118f + eta * (0.1014f - eta * (0.965241f + eta * 0.130607f));
  return (eta - 1.0f) / (4.08567f + 1.00071f * eta);
}

float oren_nayar_G(float mu) {
  if (mu < 1e-6f) return (0.5f * kPi - 2.0f / 3.0f) - mu;  // Cycles' Taylor branch near the horizon
  const float s = std::sqrt(std::max(0.0f, 1.0f - mu * mu));
  const float theta = std::acos(std::clamp(mu, -1.0f, 1.0f));
  return s * (theta - 2.0f / 3.0f - s * mu) + (2.0f / 3.0f) * (s / mu) * (1.0f - s * s * s);
}

namespace principled_v2_detail {

namespace {

// s of the real-Fresnel generalised Schlick mode at cosine c (bsdf_microfacet.h).
float real_fresnel_s(float c, float eta, float F0_real) {
  return std::clamp((fresnel_dielectric(c, eta) - F0_real) / (1.0f - F0_real), 0.0f, 1.0f);
}

}  // namespace

template <class T>
Vertex<T> prepare(const Inputs<T>& in, const MaterialParams& p, Vec3 wo, bool multiscatter) {
  Vertex<T> v;
  v.mu = wo.z;
  v.above = wo.z > 0.0f;
  if (!v.above) return v;
  const float mu = wo.z;
  const T m = saturate_t(in.metallic);
  const T r = clamp_by_value(in.roughness, kPrincipledMinRoughness, 1.0f);
  v.alpha = r * r;
  v.lambda_o = lambda_ggx(wo, v.alpha);
  Rgb<T> base, base_c;
  Rgb<float> tint;
  for (int c = 0; c < 3; ++c) {
    base[c] = max_by_value(in.base[c], T(0.0f));
    base_c[c] = min_by_value(base[c], T(1.0f));
    tint[c] = std::max(p.specular_tint_color[c], 0.0f);
  }

  // Multiscatter GGX: E(r, mu), E_avg(r) and the darkening Dk = E + Fms (1 - E) of a
  // lobe with average Fresnel Fss (microfacet_ggx_preserve_energy); the lobe's value
  // is scaled by 1 / E and its weight by Dk.
  T E(1.0f), E_avg(1.0f);
  if (multiscatter) {
    E = cycles_table_read(CyclesTable::GgxE, r, mu);
    E_avg = cycles_table_read(CyclesTable::GgxEavg, r);
  }
  auto darkening = [&](const T& Fss) {
    const T Fms = Fss * E_avg / (1.0f - Fss * (1.0f - E_avg));
    return E + Fms * (1.0f - E);
  };

  // Metal: F82-tint GGX, weight m (closure.h "Metallic component").
  float sw_metal = 0.0f;
  {
    const T s5 = cycles_table_read(CyclesTable::GenSchlickS, r, mu, 0.5f);  // exponent 5
    const bool white = std::min(tint[0], 1.0f) == 1.0f && std::min(tint[1], 1.0f) == 1.0f &&
                       std::min(tint[2], 1.0f) == 1.0f;
    for (int c = 0; c < 3; ++c) {
      const T& F0 = base_c[c];
      v.F0_metal[c] = F0;
      v.B_metal[c] = white ? T(0.0f) : fresnel_f82tint_B(F0, std::min(tint[c], 1.0f));
      if (multiscatter) {
        const T Dk = darkening(F0 + (1.0f - F0) * (1.0f / 21.0f) - v.B_metal[c] * (1.0f / 126.0f));
        v.w_metal[c] = m * Dk / E;
      } else {
        v.w_metal[c] = m;
      }
    }
    // Pick weight as Cycles' (m lerp(F0, 1, s5) [Dk]) with the nominal base colour (see principled_v2.h).
    const float F0n = kNominalBaseColour, est = F0n + (1.0f - F0n) * value_of(s5);
    const float dk = multiscatter ? value_of(darkening(T(F0n + (1.0f - F0n) / 21.0f))) : 1.0f;
    sw_metal = value_of(m) * est * dk;
  }
  const T W = 1.0f - m;

  // Dielectric specular over the diffuse (generalised Schlick, real-Fresnel mode),
  // and the layering weight of what lies under it (closure_layering_weight).
  const SpecularIor si = specular_ior(p.ior, p.specular_ior_level);
  T W_diffuse = W;
  float sw_dielectric = 0.0f;
  if (si.eta != 1.0f && value_of(W) >= kClosureWeightCutoff) {
    v.has_dielectric = true;
    v.eta = si.eta;
    v.F0_real = F0_from_ior(si.eta);
    for (int c = 0; c < 3; ++c) v.F0_tinted[c] = std::clamp(si.F0 * tint[c], 0.0f, 1.0f);
    // Albedo estimate lerp(F0', 1, s_tab) -- zero when the Fresnel at mu is zero.
    const float z = std::sqrt(std::fabs((si.eta - 1.0f) / (si.eta + 1.0f)));
    const T s_tab = cycles_table_read(CyclesTable::GenSchlickIorS, r, mu, z);
    const float s_mu = real_fresnel_s(mu, v.eta, v.F0_real);
    bool zero_at_mu = true;
    for (int c = 0; c < 3; ++c) zero_at_mu = zero_at_mu && v.F0_tinted[c] + (1.0f - v.F0_tinted[c]) * s_mu == 0.0f;
    const float s_bar = std::clamp((fresnel_dielectric_Fss(v.eta) - v.F0_real) / (1.0f - v.F0_real), 0.0f, 1.0f);
    Rgb<T> A;  // albedo estimate over the weight W
    float est = 0.0f, dk = 0.0f;
    for (int c = 0; c < 3; ++c) {
      const float F0 = v.F0_tinted[c];
      A[c] = zero_at_mu ? T(0.0f) : F0 + (1.0f - F0) * s_tab;
      est += value_of(A[c]);
      if (multiscatter) {
        const T Dk = darkening(T(F0 + (1.0f - F0) * s_bar));
        v.w_dielectric[c] = W * Dk / E;
        A[c] = A[c] * Dk;
        dk += value_of(Dk);
      } else {
        v.w_dielectric[c] = W;
      }
    }
    sw_dielectric = value_of(W) * est / 3.0f * (multiscatter ? dk / 3.0f : 1.0f);
    const T A_max = max_by_value(A[0], max_by_value(A[1], A[2]));
    W_diffuse = W * saturate_t(1.0f - A_max);
  }

  // Diffuse: Lambert, or the energy-preserving Oren-Nayar from Diffuse Roughness.
  for (int c = 0; c < 3; ++c) v.w_diffuse[c] = base[c] * W_diffuse;
  const float sw_diffuse = kNominalBaseColour * value_of(W_diffuse);  // Cycles: avg(base) W_diffuse
  const float sigma = std::clamp(p.diffuse_roughness, 0.0f, 1.0f);
  if (sigma >= kClosureWeightCutoff) {
    v.oren_nayar = true;
    v.on_a = 1.0f / (kPi + sigma * (0.5f * kPi - 2.0f / 3.0f));
    v.on_b = sigma * v.on_a;
    const float E_on_avg = v.on_a * kPi + ((2.0f * kPi - 5.6f) / 3.0f) * v.on_b;
    const float E_on_mu = v.on_a * kPi + v.on_b * oren_nayar_G(mu);
    for (int c = 0; c < 3; ++c) {
      const T rho = saturate_t(base[c]);
      const T Ems = (1.0f / kPi) * rho * rho * (E_on_avg / (1.0f - E_on_avg)) / (1.0f - rho * (1.0f - E_on_avg));
      v.on_ms[c] = Ems * (1.0f - E_on_mu);
    }
  }
  v.sw_specular = sw_metal + sw_dielectric;
  v.sw_diffuse = std::fabs(sw_diffuse);
  return v;
}

template <class T>
Rgb<T> evaluate(const Vertex<T>& v, Vec3 wo, Vec3 wi) {
  Rgb<T> f{T(0.0f), T(0.0f), T(0.0f)};
  if (!v.above || !(wi.z > 0.0f)) return f;
  // The two GGX lobes: S (D G2 / (4 mu)) times their weighted Fresnel.
  const Vec3 h = normalize(wo + wi);
  if (h.z > 0.0f) {
    const float c = dot(wo, h);
    const T G2 = 1.0f / (1.0f + v.lambda_o + lambda_ggx(wi, v.alpha));
    const T S = ggx_D_t(h, v.alpha) * G2 * (0.25f / v.mu);
    const float s = v.has_dielectric ? real_fresnel_s(c, v.eta, v.F0_real) : 0.0f;
    for (int k = 0; k < 3; ++k) {
      T F = v.w_metal[k] * fresnel_f82(c, v.F0_metal[k], v.B_metal[k]);
      if (v.has_dielectric) F = F + v.w_dielectric[k] * (v.F0_tinted[k] + (1.0f - v.F0_tinted[k]) * s);
      f[k] = S * F;
    }
  }
  // The diffuse base.
  const Rgb<T> d = evaluate_diffuse(v, wo, wi);
  for (int k = 0; k < 3; ++k) f[k] = f[k] + d[k];
  return f;
}

template <class T>
Rgb<T> evaluate_diffuse(const Vertex<T>& v, Vec3 wo, Vec3 wi) {
  Rgb<T> f{T(0.0f), T(0.0f), T(0.0f)};
  if (!v.above || !(wi.z > 0.0f)) return f;
  if (v.oren_nayar) {
    float t = dot(wo, wi) - wi.z * wo.z;
    if (t > 0.0f) t /= std::max(wi.z, wo.z) + FLT_MIN;
    const float single = v.on_a + v.on_b * t;
    const float E_on_i = v.on_a * kPi + v.on_b * oren_nayar_G(wi.z);
    for (int k = 0; k < 3; ++k) f[k] = v.w_diffuse[k] * (wi.z * (single + v.on_ms[k] * (1.0f - E_on_i)));
  } else {
    for (int k = 0; k < 3; ++k) f[k] = v.w_diffuse[k] * (wi.z * kInvPi);
  }
  return f;
}

template Vertex<float> prepare<float>(const Inputs<float>&, const MaterialParams&, Vec3, bool);
template Vertex<Dual<5>> prepare<Dual<5>>(const Inputs<Dual<5>>&, const MaterialParams&, Vec3, bool);
template Rgb<float> evaluate<float>(const Vertex<float>&, Vec3, Vec3);
template Rgb<float> evaluate_diffuse<float>(const Vertex<float>&, Vec3, Vec3);
template Rgb<Dual<5>> evaluate<Dual<5>>(const Vertex<Dual<5>>&, Vec3, Vec3);

}  // namespace principled_v2_detail

using namespace principled_v2_detail;

PrincipledV2Bsdf::PrincipledV2Bsdf(const MaterialParams& p, Vec3 wo, bool multiscatter, float min_specular_prob)
    : p_(p), wo_(wo), multiscatter_(multiscatter) {
  const Inputs<float> in{{p.albedo.x, p.albedo.y, p.albedo.z}, p.roughness, p.metallic};
  v_ = prepare(in, p, wo, multiscatter);
  const float total = v_.sw_specular + v_.sw_diffuse;
  const float hi = 1.0f - kMinDiffuseProb, lo = std::min(min_specular_prob, hi);
  p_spec_ = total > 0.0f ? std::clamp(v_.sw_specular / total, lo, hi) : 0.5f;
}

float PrincipledV2Bsdf::cycles_specular_probability() const {
  const float total = v_.sw_specular + v_.sw_diffuse;
  return total > 0.0f ? v_.sw_specular / total : 0.0f;
}

float PrincipledV2Bsdf::specular_pdf(Vec3 wi) const {
  // Visible normals reflected about h: D(h) / (4 mu (1 + Lambda(wo))).
  const Vec3 h = normalize(wo_ + wi);
  if (!(h.z > 0.0f)) return 0.0f;
  return ggx_D_t(h, v_.alpha) * 0.25f / (v_.mu * (1.0f + v_.lambda_o));
}

Vec3 PrincipledV2Bsdf::eval(Vec3 wi) const {
  const Rgb<float> f = evaluate(v_, wo_, wi);
  return Vec3(f[0], f[1], f[2]);
}

Vec3 PrincipledV2Bsdf::eval_diffuse(Vec3 wi) const {
  const Rgb<float> f = evaluate_diffuse(v_, wo_, wi);
  return Vec3(f[0], f[1], f[2]);
}

Vec3 PrincipledV2Bsdf::eval_diffuse_at(Vec3 wo_d, Vec3 wi_d) const {
  const Rgb<float> f = evaluate_diffuse(v_, wo_d, wi_d);
  return Vec3(f[0], f[1], f[2]);
}

float PrincipledV2Bsdf::pdf(Vec3 wi) const {
  if (!v_.above || !(wi.z > 0.0f)) return 0.0f;
  return p_spec_ * specular_pdf(wi) + (1.0f - p_spec_) * wi.z * kInvPi;
}

BsdfEvalPdf PrincipledV2Bsdf::eval_pdf(Vec3 wi) const { return {eval(wi), pdf(wi)}; }

BsdfSample PrincipledV2Bsdf::sample(float u1, float u2, float u3) const {
  BsdfSample s;
  if (!v_.above) return s;
  Vec3 wi;
  if (u1 < p_spec_) {
    const Vec3 h = sample_ggx_vndf(wo_, v_.alpha, u2, u3);
    wi = normalize(reflect(wo_, h));
  } else {
    wi = square_to_cosine_hemisphere(u2, u3);
  }
  if (!(wi.z > 0.0f)) return s;  // reflected below the surface: Cycles rejects it too
  const BsdfEvalPdf ep = eval_pdf(wi);
  if (!(ep.pdf > 0.0f) || !std::isfinite(ep.pdf)) return s;
  s.wi = wi;
  s.pdf = ep.pdf;
  s.weight = ep.f / ep.pdf;
  s.valid = true;
  return s;
}

Vec3 PrincipledV2Bsdf::eval_grad(Vec3 wi, Vec3 d_f, MaterialGrad& g) const {
  if (!v_.above || !(wi.z > 0.0f)) return Vec3(0.0f);
  if (!grad_vertex_) {
    const Inputs<Grad> in{{Grad::variable(p_.albedo.x, 0), Grad::variable(p_.albedo.y, 1), Grad::variable(p_.albedo.z, 2)},
                          Grad::variable(p_.roughness, 3), Grad::variable(p_.metallic, 4)};
    grad_vertex_ = prepare(in, p_, wo_, multiscatter_);
  }
  const Rgb<Grad> f = evaluate(*grad_vertex_, wo_, wi);
  for (int c = 0; c < 3; ++c) {
    for (int k = 0; k < 3; ++k) g.d_albedo[k] += d_f[c] * f[c].d[size_t(k)];
    g.d_roughness += d_f[c] * f[c].d[3];
    g.d_metallic += d_f[c] * f[c].d[4];
  }
  return Vec3(f[0].v, f[1].v, f[2].v);
}

}  // namespace ptir
