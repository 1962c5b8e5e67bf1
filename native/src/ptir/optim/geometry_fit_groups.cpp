#include "ptir/optim/geometry_fit_groups.h"

#include <cmath>

#include "ptir/core/error.h"
#include "ptir/optim/geometry_fit.h"

namespace ptir {

int fit_group_width(int k, int sh_stride) {
  static const int widths[kFitGroups] = {3, 3, 4, 1, 3, -1, 3};
  return k == kFitShRest ? sh_stride - 3 : widths[k];
}

ParamKind fit_group_kind(int k) {
  static const ParamKind kinds[kFitGroups] = {ParamKind::GaussianPosition, ParamKind::GaussianLogScale,
                                              ParamKind::GaussianRotation, ParamKind::GaussianOpacity,
                                              ParamKind::GaussianShDc,     ParamKind::GaussianShRest,
                                              ParamKind::GaussianNormal};
  return kinds[k];
}

std::vector<ParameterGroup> make_fit_groups(const GaussianField& f, const GeometryFitSettings& s, float extent) {
  const size_t n = f.size();
  const int stride = f.sh_stride();
  std::vector<ParameterGroup> g(kFitGroups);
  const float lrs[kFitGroups] = {s.lr_position * extent, s.lr_scale, s.lr_rotation, s.lr_opacity,
                                 s.lr_sh_dc,             s.lr_sh_rest, s.lr_normal};
  for (int k = 0; k < kFitGroups; ++k) {
    g[k].kind = fit_group_kind(k);
    g[k].lr = lrs[k];
    g[k].raw.resize(n * size_t(fit_group_width(k, stride)));
  }
  const bool has_sh = f.sh.size() == n * size_t(stride);
  for (size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) {
      g[kFitPosition].raw[3 * i + c] = f.position[i][c];
      g[kFitLogScale].raw[3 * i + c] = std::log(std::max(f.scale[i][c], 1e-12f));
      g[kFitNormal].raw[3 * i + c] = f.normal[i][c];
      g[kFitShDc].raw[3 * i + c] = has_sh ? f.sh[i * stride + c] : 0.0f;
    }
    for (int c = 0; c < 4; ++c) g[kFitRotation].raw[4 * i + c] = f.rotation[i][c];
    g[kFitOpacity].raw[i] = logit_clamped(f.opacity[i]);
    for (int c = 3; c < stride; ++c) g[kFitShRest].raw[i * (stride - 3) + (c - 3)] = has_sh ? f.sh[i * stride + c] : 0.0f;
  }
  return g;
}

void apply_fit_groups(const std::vector<ParameterGroup>& g, GaussianField& f) {
  const size_t n = g[kFitOpacity].raw.size();
  const int stride = f.sh_stride();
  f.position.resize(n);
  f.scale.resize(n);
  f.rotation.resize(n);
  f.opacity.resize(n);
  f.normal.resize(n);
  f.sh.resize(n * size_t(stride));
  for (size_t i = 0; i < n; ++i) {
    const float* p = &g[kFitPosition].raw[3 * i];
    const float* s = &g[kFitLogScale].raw[3 * i];
    const float* q = &g[kFitRotation].raw[4 * i];
    const float* nr = &g[kFitNormal].raw[3 * i];
    f.position[i] = Vec3(p[0], p[1], p[2]);
    f.scale[i] = Vec3(std::exp(s[0]), std::exp(s[1]), std::exp(s[2]));
    const float ql = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    f.rotation[i] = ql > 0 ? std::array<float, 4>{q[0] / ql, q[1] / ql, q[2] / ql, q[3] / ql}
                           : std::array<float, 4>{1.0f, 0.0f, 0.0f, 0.0f};
    f.opacity[i] = sigmoid(g[kFitOpacity].raw[i]);
    const Vec3 nv(nr[0], nr[1], nr[2]);
    f.normal[i] = length(nv) > 0 ? normalize(nv) : Vec3(0.0f, 0.0f, 1.0f);
    for (int c = 0; c < 3; ++c) f.sh[i * stride + c] = g[kFitShDc].raw[3 * i + c];
    for (int c = 3; c < stride; ++c) f.sh[i * stride + c] = g[kFitShRest].raw[i * (stride - 3) + (c - 3)];
  }
}

std::vector<std::vector<float>> fit_raw_gradients(const std::vector<ParameterGroup>& g, const SplatGradients& d,
                                                  const GaussianField& f) {
  const size_t n = f.size();
  const int stride = f.sh_stride();
  std::vector<std::vector<float>> out(kFitGroups);
  for (int k = 0; k < kFitGroups; ++k) out[k].assign(g[k].raw.size(), 0.0f);
  for (size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) {
      out[kFitPosition][3 * i + c] = d.position[i][c];
      out[kFitLogScale][3 * i + c] = d.log_scale[i][c];
      out[kFitShDc][3 * i + c] = d.sh[i * stride + c];
    }
    for (int c = 3; c < stride; ++c) out[kFitShRest][i * (stride - 3) + (c - 3)] = d.sh[i * stride + c];
    // Normalised on use: the gradient projected onto the tangent, over the raw length.
    const float* q = &g[kFitRotation].raw[4 * i];
    const float ql = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    const auto& uq = f.rotation[i];
    const auto& dq = d.rotation[i];
    const float qd = uq[0] * dq[0] + uq[1] * dq[1] + uq[2] * dq[2] + uq[3] * dq[3];
    for (int c = 0; c < 4; ++c) out[kFitRotation][4 * i + c] = ql > 0 ? (dq[c] - qd * uq[c]) / ql : 0.0f;
    const float* nr = &g[kFitNormal].raw[3 * i];
    const float nl = std::sqrt(nr[0] * nr[0] + nr[1] * nr[1] + nr[2] * nr[2]);
    const Vec3 dn = d.normal[i] - dot(d.normal[i], f.normal[i]) * f.normal[i];
    for (int c = 0; c < 3; ++c) out[kFitNormal][3 * i + c] = nl > 0 ? dn[c] / nl : 0.0f;
    const float s = f.opacity[i];
    out[kFitOpacity][i] = d.opacity[i] * s * (1.0f - s);
  }
  for (auto& v : out)
    for (float& x : v)
      if (!std::isfinite(x)) x = 0.0f;
  return out;
}

}  // namespace ptir
