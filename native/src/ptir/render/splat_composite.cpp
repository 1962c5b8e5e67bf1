#include "ptir/render/splat_composite.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>

#include "ptir/core/error.h"

namespace ptir {

void SplatGradients::resize(size_t n, int sh_stride) {
  position.assign(n, Vec3(0.0f));
  log_scale.assign(n, Vec3(0.0f));
  normal.assign(n, Vec3(0.0f));
  rotation.assign(n, {0.0f, 0.0f, 0.0f, 0.0f});
  opacity.assign(n, 0.0f);
  sh.assign(n * size_t(sh_stride), 0.0f);
}

void SplatGradients::set_zero() { resize(position.size(), position.empty() ? 0 : int(sh.size() / position.size())); }

void SplatGradients::add(const SplatGradients& o) {
  for (size_t i = 0; i < position.size(); ++i) {
    position[i] += o.position[i];
    log_scale[i] += o.log_scale[i];
    normal[i] += o.normal[i];
    for (int k = 0; k < 4; ++k) rotation[i][k] += o.rotation[i][k];
    opacity[i] += o.opacity[i];
  }
  for (size_t i = 0; i < sh.size(); ++i) sh[i] += o.sh[i];
}

std::array<float, 4> quat_to_mat3_adjoint(const std::array<float, 4>& q, const Mat3& dR) {
  const float w = q[0], x = q[1], y = q[2], z = q[3];
  const auto& g = dR.m;
  float dw = 2 * (-z * g[0][1] + y * g[0][2] + z * g[1][0] - x * g[1][2] - y * g[2][0] + x * g[2][1]);
  float dx = 2 * (y * g[0][1] + z * g[0][2] + y * g[1][0] - 2 * x * g[1][1] - w * g[1][2] + z * g[2][0] + w * g[2][1] -
                  2 * x * g[2][2]);
  float dy = 2 * (-2 * y * g[0][0] + x * g[0][1] + w * g[0][2] + x * g[1][0] + z * g[1][2] - w * g[2][0] + z * g[2][1] -
                  2 * y * g[2][2]);
  float dz = 2 * (-2 * z * g[0][0] - w * g[0][1] + x * g[0][2] + w * g[1][0] - 2 * z * g[1][1] + y * g[1][2] +
                  x * g[2][0] + y * g[2][1]);
  return {dw, dx, dy, dz};
}

namespace {

// The normal sum covers the hits in front of the median depth (T > 1/2 before
// them): the surface the pseudo-normals describe, not the far side seen through it.
constexpr float kFrontT = 0.5f;

// Per-ray compositing state, shared by the forward and the replay.
struct RayState {
  float T = 1.0f;
  Vec3 colour, normal_sum, acc_colour, acc_normal;
  float depth_sum = 0.0f;
  float median_t = 0.0f;
  float distortion = 0.0f;  // forward: Ldist so far
  float acc_depth = 0.0f, acc_distortion = 0.0f;  // replay: S_< and sum_{j<=i} w_j g_j
};

// Forward step for hit h.
inline void composite(const GaussianField& f, const Ray& ray, const GaussianHit& h, RayState& st) {
  const float w = st.T * h.alpha;
  st.colour += w * f.sh_colour(h.id, ray.d);
  if (st.T > kFrontT) st.normal_sum += w * f.normal[h.id];
  st.distortion += 2.0f * w * (h.t * (1.0f - st.T) - st.depth_sum);  // pairs with the hits in front
  st.depth_sum += w * h.t;
  if (st.T > 0.5f && st.T * (1.0f - h.alpha) <= 0.5f) st.median_t = h.t;
  st.T *= 1.0f - h.alpha;
}

// The chain from dL/dalpha (alpha = sigma rho) and dL/dt_peak into the Gaussian's
// sigma and geometry.
void hit_backward(const GaussianField& f, const Ray& ray, uint32_t id, float alpha, float d_alpha, float d_t,
                  const CullSettings& cull, SplatGradients& g) {
  const bool through_alpha = alpha < cull.max_alpha && d_alpha != 0.0f;  // clamped: flat
  if (!through_alpha && d_t == 0.0f) return;
  const Mat3 R = f.rotation_matrix(id);
  const Vec3 s = f.scale[id], mu = f.position[id];
  // Unit space: o' = S^-1 R^T (o - mu), d' = S^-1 R^T d; u = o' + t d'.
  const Vec3 po = ray.o - mu;
  Vec3 ou, du;
  for (int k = 0; k < 3; ++k) {
    ou[k] = dot(R.col(k), po) / s[k];
    du[k] = dot(R.col(k), ray.d) / s[k];
  }
  const float dd = dot(du, du);
  const float t = -dot(ou, du) / dd;
  const Vec3 u = ou + t * du;
  Mat3 dR;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) dR.m[r][k] = 0.0f;
  if (through_alpha) {
    const float rho = std::exp(-0.5f * dot(u, u));
    g.opacity[id] += d_alpha * rho;
    const float d_d2 = d_alpha * (-0.5f * alpha);
    const Vec3 pm = po + t * ray.d;  // p_peak - mu
    Vec3 mtu(0.0f);
    for (int k = 0; k < 3; ++k) {
      mtu += (u[k] / s[k]) * R.col(k);
      g.log_scale[id][k] += d_d2 * (-2.0f * u[k] * u[k]);
      const Vec3 dcol = (d_d2 * 2.0f * u[k] / s[k]) * pm;
      for (int r = 0; r < 3; ++r) dR.m[r][k] += dcol[r];
    }
    g.position[id] += (-2.0f * d_d2) * mtu;
  }
  if (d_t != 0.0f) {
    const float scale = d_t / dd;
    for (int k = 0; k < 3; ++k) {
      g.position[id] += (scale * du[k] / s[k]) * R.col(k);
      g.log_scale[id][k] += scale * 2.0f * du[k] * u[k];
      const Vec3 dcol = (-scale / s[k]) * (du[k] * po + (ou[k] + 2.0f * t * du[k]) * ray.d);
      for (int r = 0; r < 3; ++r) dR.m[r][k] += dcol[r];
    }
  }
  const auto dq = quat_to_mat3_adjoint(f.rotation[id], dR);
  for (int k = 0; k < 4; ++k) g.rotation[id][k] += dq[k];
}

// Replay step for hit h: the adjoint of everything hit h touches.
inline void replay(const GaussianField& f, const CullSettings& cull, const Ray& ray, const GaussianHit& h,
                   const SplatRaySample& s, const SplatRayAdjoint& adj, RayState& st, float* basis, SplatGradients& g) {
  const float alpha = h.alpha, w = st.T * alpha;
  const Vec3 c = f.sh_colour(h.id, ray.d), n = f.normal[h.id];
  const bool front = st.T > kFrontT;
  st.acc_colour += w * c;
  if (front) st.acc_normal += w * n;
  const float inv = 1.0f / (1.0f - alpha);
  const Vec3 rest_c = s.colour - st.acc_colour, rest_n = s.normal_sum - st.acc_normal;
  float d_alpha = dot(adj.colour, st.T * c - inv * rest_c) + adj.opacity * s.transmittance * inv;
  if (adj.normal_to_weights) d_alpha += dot(adj.normal_sum, (front ? st.T : 0.0f) * n - inv * rest_n);
  float d_t = 0.0f;
  if (adj.distortion != 0.0f) {
    // Weight and depth sums in front of and behind hit i (module comment).
    const float w_front = 1.0f - st.T, w_back = (1.0f - s.transmittance) - w_front - w;
    const float s_front = st.acc_depth, s_back = s.depth_sum - s_front - w * h.t;
    const float gi = 2.0f * (h.t * w_front - s_front + s_back - h.t * w_back);
    st.acc_distortion += w * gi;
    d_alpha += adj.distortion * (st.T * gi - inv * (2.0f * s.distortion - st.acc_distortion));
    d_t = adj.distortion * 2.0f * w * (w_front - w_back);
  }
  st.acc_depth += w * h.t;
  // Colour: dC/dc_i = w_i, through the SH basis where the colour is not clamped at 0.
  const int stride = f.sh_stride(), nk = stride / 3;
  if (f.sh.size() >= (size_t(h.id) + 1) * size_t(stride)) {
    sh_basis(f.sh_degree, ray.d, basis);
    float* gs = g.sh.data() + size_t(h.id) * size_t(stride);
    for (int ch = 0; ch < 3; ++ch) {
      if (!(c[ch] > 0.0f)) continue;
      const float gc = w * adj.colour[ch];
      for (int k = 0; k < nk; ++k) gs[k * 3 + ch] += basis[k] * gc;
    }
  }
  if (front) g.normal[h.id] += w * adj.normal_sum;
  hit_backward(f, ray, h.id, alpha, d_alpha, d_t, cull, g);
  st.T *= 1.0f - alpha;
}

}  // namespace

SplatRaySample trace_splat(const SceneAccel& accel, const Ray& ray, Vec3 background) {
  const GaussianField& f = accel.field();
  RayState st;
  accel.walk(ray, [&](const GaussianHit& h) { return composite(f, ray, h, st), true; }, nullptr, true);
  return {st.colour + st.T * background, st.T, st.normal_sum, st.depth_sum, st.distortion};
}

void trace_splat_backward(const SceneAccel& accel, const Ray& ray, Vec3 background, const SplatRaySample& s,
                          const SplatRayAdjoint& adj, SplatGradients& g) {
  (void)background;  // its share of C is what remains after the last hit
  const GaussianField& f = accel.field();
  const CullSettings& cull = accel.settings().cull;
  RayState st;
  float basis[kMaxShCoefficients];
  accel.walk(ray, [&](const GaussianHit& h) { return replay(f, cull, ray, h, s, adj, st, basis, g), true; }, nullptr, true);
}

namespace {

// The pixels of a 4x4 block of rows [y0, y1) starting at column bx.
struct Block {
  int n = 0, xs[16], ys[16];
  Ray rays[16];
};

Block make_block(const Camera& cam, int bx, int by, int y_end) {
  Block b;
  for (int y = by; y < std::min(by + 4, y_end); ++y)
    for (int x = bx; x < std::min(bx + 4, cam.width); ++x) {
      b.xs[b.n] = x, b.ys[b.n] = y;
      b.rays[b.n++] = cam.generate_ray(float(x) + 0.5f, float(y) + 0.5f);
    }
  return b;
}

SplatRaySample sample_at(const SplatImage& im, int x, int y) {
  SplatRaySample s;
  s.colour = Vec3(im.colour.at(x, y, 0), im.colour.at(x, y, 1), im.colour.at(x, y, 2));
  s.transmittance = 1.0f - im.opacity.at(x, y, 0);
  s.normal_sum = Vec3(im.normal.at(x, y, 0), im.normal.at(x, y, 1), im.normal.at(x, y, 2));
  s.depth_sum = im.depth.at(x, y, 0) * (1.0f - s.transmittance);
  s.distortion = im.distortion.at(x, y, 0);
  return s;
}

void check_adjoint(const Image* img, const Camera& cam, int channels, const char* what) {
  if (img && (img->width != cam.width || img->height != cam.height || img->channels < channels))
    throw Error(std::string(what) + " adjoint must be " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                " with at least " + std::to_string(channels) + " channel(s)");
}

}  // namespace

SplatImage render_splat(const SceneAccel& accel, const Camera& cam, Vec3 background, const RenderControl& control) {
  const GaussianField& f = accel.field();
  SplatImage out;
  out.colour = Image(cam.width, cam.height, {"R", "G", "B"});
  out.opacity = Image(cam.width, cam.height, {"A"});
  out.normal = Image(cam.width, cam.height, {"X", "Y", "Z"});
  out.depth = Image(cam.width, cam.height, {"Z"});
  out.median_depth = Image(cam.width, cam.height, {"Z"});
  out.distortion = Image(cam.width, cam.height, {"Y"});
  const int rows4 = (cam.height + 3) / 4;
  tbb::parallel_for(0, rows4, [&](int br) {
    if (control.cancel && control.cancel->load()) return;
    for (int bx = 0; bx < cam.width; bx += 4) {
      Block b = make_block(cam, bx, br * 4, cam.height);
      RayState st[16];
      WalkEnd ends[16];
      accel.walk_packet(
          b.rays, b.n, [&](int l, const GaussianHit& h) { return composite(f, b.rays[l], h, st[l]), true; }, ends,
          nullptr, true);
      for (int l = 0; l < b.n; ++l) {
        const int x = b.xs[l], y = b.ys[l];
        const Vec3 c = st[l].colour + st[l].T * background;
        const float o = 1.0f - st[l].T;
        for (int k = 0; k < 3; ++k) out.colour.at(x, y, k) = c[k], out.normal.at(x, y, k) = st[l].normal_sum[k];
        out.opacity.at(x, y, 0) = o;
        out.depth.at(x, y, 0) = o > 0.0f ? st[l].depth_sum / o : 0.0f;
        out.median_depth.at(x, y, 0) = st[l].median_t;
        out.distortion.at(x, y, 0) = st[l].distortion;
      }
    }
  });
  if (control.cancel && control.cancel->load()) throw Cancelled();
  return out;
}

void render_splat_backward(const SceneAccel& accel, const Camera& cam, Vec3 background, const SplatImage& fwd,
                           const Image* d_colour, const Image* d_opacity, const Image* d_normal, SplatGradients& grads,
                           const RenderControl& control, bool normal_to_weights, const Image* d_distortion) {
  (void)background;
  check_adjoint(d_colour, cam, 3, "colour");
  check_adjoint(d_opacity, cam, 1, "opacity");
  check_adjoint(d_normal, cam, 3, "normal");
  check_adjoint(d_distortion, cam, 1, "distortion");
  const GaussianField& f = accel.field();
  const CullSettings& cull = accel.settings().cull;
  const int rows4 = (cam.height + 3) / 4;
  const int chunks = std::max(1, std::min(rows4, tbb::this_task_arena::max_concurrency()));
  std::vector<SplatGradients> partial(static_cast<size_t>(chunks));
  tbb::parallel_for(0, chunks, [&](int chunk) {
    SplatGradients& g = partial[size_t(chunk)];
    g.resize(f.size(), f.sh_stride());
    float basis[kMaxShCoefficients];
    for (int br = chunk; br < rows4; br += chunks) {
      if (control.cancel && control.cancel->load()) return;
      for (int bx = 0; bx < cam.width; bx += 4) {
        Block b = make_block(cam, bx, br * 4, cam.height);
        RayState st[16];
        SplatRaySample smp[16];
        SplatRayAdjoint adj[16];
        for (int l = 0; l < b.n; ++l) {
          const int x = b.xs[l], y = b.ys[l];
          smp[l] = sample_at(fwd, x, y);
          if (d_colour) adj[l].colour = Vec3(d_colour->at(x, y, 0), d_colour->at(x, y, 1), d_colour->at(x, y, 2));
          if (d_opacity) adj[l].opacity = d_opacity->at(x, y, 0);
          if (d_normal) adj[l].normal_sum = Vec3(d_normal->at(x, y, 0), d_normal->at(x, y, 1), d_normal->at(x, y, 2));
          if (d_distortion) adj[l].distortion = d_distortion->at(x, y, 0);
          adj[l].normal_to_weights = normal_to_weights;
        }
        WalkEnd ends[16];
        accel.walk_packet(
            b.rays, b.n,
            [&](int l, const GaussianHit& h) { return replay(f, cull, b.rays[l], h, smp[l], adj[l], st[l], basis, g), true; },
            ends, nullptr, true);
      }
    }
  });
  if (control.cancel && control.cancel->load()) throw Cancelled();
  for (const SplatGradients& g : partial) grads.add(g);
}

}  // namespace ptir
