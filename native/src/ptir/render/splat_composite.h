// Ray-traced compositing of the Gaussians' SH radiance along primary rays, and
// its hand-written adjoint with respect to every Gaussian's geometry (position,
// log scale, rotation), opacity, SH coefficients and shading normal: what the
// geometry stage (optim/geometry_fit.h) differentiates.
//
// Forward, per ray (the walk and response of rendering: SceneAccel::walk with the
// opacity-aware k-buffer, alpha_i = min(0.99, sigma_i rho_i)):
//   w_i = T_i alpha_i,  T_{i+1} = T_i (1 - alpha_i)
//   C = sum w_i c_i(d) + T_end * background      (c_i: SH colour, display space)
//   O = 1 - T_end,  Nsum = sum_{T_i > 1/2} w_i n_i,  Dsum = sum w_i t_i
//   Ldist = sum_{i,j} w_i w_j |t_i - t_j|   (Mip-NeRF 360's / 2DGS's depth distortion,
//            the pairs taken in walk order: 2 sum_i w_i sum_{j<i} w_j (t_i - t_j))
// (the normal sum stops at the median depth: the front surface, not its far side)
// A triangle ends the walk (it is treated as background); the geometry stage
// traces Gaussians only.
//
// Backward (3DGRT's scheme, memory flat in hits per ray): the forward keeps only
// C, T_end and Nsum per ray; a second walk replays the same hits front to back
// and, at hit i, knows the part of C behind it as C - sum_{j<=i} w_j c_j. Then
//   dC/dalpha_i = T_i c_i - (C - sum_{j<=i} w_j c_j) / (1 - alpha_i)
//   dO/dalpha_i = T_end / (1 - alpha_i)     (likewise for Nsum with n_i)
//   dalpha/dsigma = rho,  dalpha/dD^2 = -alpha / 2  (0 where alpha is clamped)
// and with u = o' + t_peak d' (the peak in the Gaussian's unit space, D^2 = |u|^2;
// t_peak minimises D^2, so its own variation drops out):
//   dD^2/dmu = -2 M^T u (M = S^-1 R^T),  dD^2/dlog s_k = -2 u_k^2,
//   dD^2/dR_col_k = 2 u_k (p_peak - mu) / s_k,  then R(q) by the chain rule.
// The distortion, with W_< = 1 - T_i and S_< the weight and depth sums in front of
// hit i (W_>, S_> behind it; O and Dsum from the forward give those):
//   dLdist/dw_i = g_i = 2 (t_i W_< - S_< + S_> - t_i W_>),  sum_i w_i g_i = 2 Ldist,
//   so dLdist/dalpha_i = T_i g_i - (2 Ldist - sum_{j<=i} w_j g_j) / (1 - alpha_i)
//   (the colour's rule with c_i = g_i), and dLdist/dt_i = 2 w_i (W_< - W_>) with
//   t_peak = -(o'.d')/(d'.d'):  dt/dmu = M^T d' / |d'|^2,
//   dt/dlog s_k = 2 d'_k u_k / |d'|^2,  dt/dR_col_k = -(d'_k (o - mu) + (o'_k + 2 t d'_k) d) / (s_k |d'|^2).
// The order of the hits (t_peak) is piecewise constant: it has no gradient, nor
// does the cull boundary (a hit entering or leaving the accepted region jumps by
// alpha >= 1/255). The depth sum is forward only (pseudo-normals are detached).
#pragma once

#include <array>
#include <vector>

#include "ptir/accel/scene_accel.h"
#include "ptir/core/render_control.h"
#include "ptir/io/image.h"
#include "ptir/scene/camera.h"

namespace ptir {

// What the forward keeps per ray.
struct SplatRaySample {
  Vec3 colour;               // sum w_i c_i + T_end * background
  float transmittance = 1;   // T_end
  Vec3 normal_sum;           // sum w_i n_i over the hits with T_i > 1/2
  float depth_sum = 0;       // sum w_i t_peak_i
  float distortion = 0;      // Ldist
};

// Adjoints of a ray's outputs.
struct SplatRayAdjoint {
  Vec3 colour;    // dL/dC
  float opacity = 0;  // dL/dO (O = 1 - T_end)
  Vec3 normal_sum;    // dL/dNsum
  float distortion = 0;  // dL/dLdist
  // false: dL/dNsum reaches the normals only, not the weights (alpha, geometry):
  // a normal term then shapes the shading normals without moving the splats.
  bool normal_to_weights = true;
};

// Gradients with respect to the field's values: position, log scale, the unit
// quaternion as stored (w, x, y, z; not projected), the activated opacity sigma,
// the SH coefficients (field.sh layout) and the stored normal n_i.
struct SplatGradients {
  std::vector<Vec3> position, log_scale, normal;
  std::vector<std::array<float, 4>> rotation;
  std::vector<float> opacity, sh;
  void resize(size_t n, int sh_stride);
  void set_zero();
  void add(const SplatGradients& o);
};

SplatRaySample trace_splat(const SceneAccel& accel, const Ray& ray, Vec3 background);

// Adds the gradient of <adj, outputs(ray)> to g, replaying the walk of `s`
// (the sample trace_splat returned for this ray and field).
void trace_splat_backward(const SceneAccel& accel, const Ray& ray, Vec3 background, const SplatRaySample& s,
                          const SplatRayAdjoint& adj, SplatGradients& g);

// Per-pixel buffers of one view (one ray through each pixel centre).
struct SplatImage {
  Image colour;  // RGB, display space
  Image opacity; // O
  Image normal;  // Nsum (not normalised)
  Image depth;   // Dsum / O (0 where O = 0)
  Image median_depth;  // t_peak of the hit where T first falls to 0.5 or below (0: never)
  Image distortion;    // Ldist
};

SplatImage render_splat(const SceneAccel& accel, const Camera& camera, Vec3 background,
                        const RenderControl& control = {});

// Backward of a view: d_colour (3 channels), d_opacity (1), d_normal (3, of
// Nsum) and d_distortion (1; any may be null) into `grads` (sized for the field). Rows are split into
// a fixed number of chunks whose partial sums are added in order: deterministic
// for a given thread count.
void render_splat_backward(const SceneAccel& accel, const Camera& camera, Vec3 background, const SplatImage& forward,
                           const Image* d_colour, const Image* d_opacity, const Image* d_normal, SplatGradients& grads,
                           const RenderControl& control = {}, bool normal_to_weights = true,
                           const Image* d_distortion = nullptr);

// dL/dq of R = quat_to_mat3(q) (unit q) given dL/dR.
std::array<float, 4> quat_to_mat3_adjoint(const std::array<float, 4>& q, const Mat3& dR);

}  // namespace ptir
