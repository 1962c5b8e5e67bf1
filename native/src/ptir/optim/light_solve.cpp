#include "ptir/optim/light_solve.h"

#include <algorithm>
#include <cmath>

#include "ptir/core/error.h"
#include "ptir/optim/losses.h"
#include "ptir/render/env_transport.h"

namespace ptir {

LightNormalEquations::LightNormalEquations(int w, int h) : width(w), height(h) {
  if (w < 1 || h < 1) throw Error("light solve: the node grid must be at least 1 x 1");
  for (int c = 0; c < 3; ++c) {
    A[c].assign(size_t(nodes()) * nodes(), 0.0);
    b[c].assign(size_t(nodes()), 0.0);
  }
}

void LightNormalEquations::add(const LightNormalEquations& o) {
  for (int c = 0; c < 3; ++c) {
    for (size_t i = 0; i < A[c].size(); ++i) A[c][i] += o.A[c][i];
    for (size_t i = 0; i < b[c].size(); ++i) b[c][i] += o.b[c][i];
    yy[c] += o.yy[c];
  }
  pixels += o.pixels;
}

void LightNormalEquations::allreduce(const Communicator& comm) {
  if (comm.size() <= 1) return;
  std::vector<float> packed;
  for (int c = 0; c < 3; ++c) {
    packed.insert(packed.end(), A[c].begin(), A[c].end());
    packed.insert(packed.end(), b[c].begin(), b[c].end());
    packed.push_back(float(yy[c]));
  }
  packed.push_back(float(pixels));
  comm.allreduce_sum(packed.data(), packed.size());
  size_t at = 0;
  for (int c = 0; c < 3; ++c) {
    for (double& v : A[c]) v = packed[at++];
    for (double& v : b[c]) v = packed[at++];
    yy[c] = packed[at++];
  }
  pixels = packed[at];
}

double LightNormalEquations::objective(const std::vector<float>& s, int c) const {
  const int n = nodes();
  double J = yy[c];
  for (int i = 0; i < n; ++i) {
    double row = 0.0;
    for (int j = 0; j < n; ++j) row += A[c][size_t(i) * n + j] * s[size_t(j) * 3 + c];
    J += s[size_t(i) * 3 + c] * (row - 2.0 * b[c][i]);
  }
  return J;
}

namespace {

// One band's scratch: a half's transport row gathered at the nodes (RGB), and
// which nodes it touched.
struct NodeRow {
  std::vector<double> value;  // nodes x 3
  std::vector<int> touched;
  std::vector<char> mark;
  explicit NodeRow(int nodes) : value(size_t(nodes) * 3, 0.0), mark(size_t(nodes), 0) {}
  void add(int node, const double* v) {
    if (!mark[node]) {
      mark[node] = 1;
      touched.push_back(node);
    }
    for (int c = 0; c < 3; ++c) value[size_t(node) * 3 + c] += v[c];
  }
  void clear() {
    for (int k : touched) {
      mark[k] = 0;
      value[size_t(k) * 3] = value[size_t(k) * 3 + 1] = value[size_t(k) * 3 + 2] = 0.0;
    }
    touched.clear();
  }
};

}  // namespace

void add_light_view(const PathTracer& tracer, const Camera& camera, const IntegratorSettings& settings,
                    const Image& target_rgb, const Image* target_alpha, float mask_threshold, float exposure,
                    bool srgb, const LatlongUpsampler& grid, LightNormalEquations& eq,
                    const std::atomic<bool>* cancel) {
  const Environment* map = tracer.scene().environment.as<Environment>();
  if (!map) throw Error("the light solve needs a lat-long environment");
  if (grid.coarse_width() != eq.width || grid.coarse_height() != eq.height)
    throw Error("light solve: the node grid and the equations differ");
  if (target_rgb.width != camera.width || target_rgb.height != camera.height || target_rgb.channels < 3)
    throw Error("light solve: the target does not match the camera");
  const int W = map->width(), nodes = eq.nodes();
  const std::vector<float>& texels = map->texels();
  // Bands of rows, each with its own equations, summed in band order: the same
  // sums on any thread count.
  const int band_rows = std::max(8, (camera.height + 31) / 32);
  const int bands = (camera.height + band_rows - 1) / band_rows;
  std::vector<LightNormalEquations> parts(size_t(bands), LightNormalEquations(eq.width, eq.height));
  std::vector<std::array<NodeRow, 2>> rows;
  for (int i = 0; i < bands; ++i) rows.push_back({NodeRow(nodes), NodeRow(nodes)});

  RenderControl control;
  control.cancel = cancel;
  render_env_transport(tracer, camera, settings, band_rows, [&](int band, const EnvTransportPixel& px) {
    const size_t p = size_t(px.y) * camera.width + px.x;
    const float coverage = 0.5f * (px.coverage[0] + px.coverage[1]);
    if (target_alpha && (target_alpha->pixels[p * target_alpha->channels] < mask_threshold || coverage < mask_threshold))
      return;
    LightNormalEquations& q = parts[size_t(band)];
    std::array<NodeRow, 2>& r = rows[size_t(band)];
    // Each half's row at the nodes: weight x current radiance x bilinear weight.
    Vec3 env_part[2];
    for (int h = 0; h < 2; ++h)
      for (const EnvLookup& l : px.lookups[h]) {
        const float* Le = &texels[size_t(l.texel) * 3];
        const double v[3] = {double(l.weight.x) * Le[0], double(l.weight.y) * Le[1], double(l.weight.z) * Le[2]};
        env_part[h] += Vec3(float(v[0]), float(v[1]), float(v[2]));
        int node[4];
        float wt[4];
        grid.taps(int(l.texel % uint32_t(W)), int(l.texel / uint32_t(W)), node, wt);
        for (int k = 0; k < 4; ++k)
          if (wt[k] > 0.0f) {
            const double vk[3] = {v[0] * wt[k], v[1] * wt[k], v[2] * wt[k]};
            r[h].add(node[k], vk);
          }
      }
    // What the emitters add (the part of the radiance no lookup carries).
    const Vec3 e = 0.5f * ((px.L[0] - env_part[0]) + (px.L[1] - env_part[1]));
    for (int c = 0; c < 3; ++c) {
      const double y = target_rgb.pixels[p * target_rgb.channels + c];
      const double slope = srgb ? srgb_encode_derivative(float(std::max(y, 0.02))) : 1.0;
      const double w = slope * slope, s2 = double(exposure) * exposure;
      const double residual = y - double(exposure) * e[c];
      // A += w s_v^2 (a b^T + b a^T) / 2; b += w s_v (a + b) / 2 residual.
      std::vector<double>& A = q.A[c];
      for (int i : r[0].touched) {
        const double ai = r[0].value[size_t(i) * 3 + c] * 0.5 * w * s2;
        for (int j : r[1].touched) {
          const double ab = ai * r[1].value[size_t(j) * 3 + c];
          A[size_t(i) * nodes + j] += ab;
          A[size_t(j) * nodes + i] += ab;
        }
      }
      for (int h = 0; h < 2; ++h)
        for (int i : r[h].touched) q.b[c][i] += 0.5 * w * exposure * r[h].value[size_t(i) * 3 + c] * residual;
      q.yy[c] += w * residual * residual;
    }
    q.pixels += 1.0;
    r[0].clear();
    r[1].clear();
  }, control);
  for (const LightNormalEquations& q : parts) eq.add(q);
}

std::vector<float> solve_light_scales(const LightNormalEquations& eq, const LightSolveSettings& settings,
                                      LightSolveReport* report) {
  const int n = eq.nodes(), W = eq.width, H = eq.height;
  std::vector<float> s(size_t(n) * 3, 1.0f);
  if (report) *report = LightSolveReport{eq.pixels, {}, {}, 0};
  // Grid neighbours: u wraps, v does not.
  std::vector<std::vector<int>> neighbours(static_cast<size_t>(n));
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      std::vector<int>& nb = neighbours[size_t(y) * W + x];
      auto link = [&](int k) {
        if (k != y * W + x && std::find(nb.begin(), nb.end(), k) == nb.end()) nb.push_back(k);
      };
      link(y * W + (x + 1) % W);
      link(y * W + (x + W - 1) % W);
      if (y > 0) link((y - 1) * W + x);
      if (y + 1 < H) link((y + 1) * W + x);
    }
  for (int c = 0; c < 3; ++c) {
    if (report) report->before[c] = eq.objective(s, c);
    double trace = 0.0;
    for (int i = 0; i < n; ++i) trace += eq.A[c][size_t(i) * n + i];
    const double mean_diag = trace / n;
    if (!(mean_diag > 0.0)) continue;  // no pixel saw the light: keep it
    // M = A + ridge I + smooth Laplacian; rhs = b + ridge 1.
    const double ridge = settings.ridge * mean_diag, smooth = settings.smooth * mean_diag;
    std::vector<double> M(eq.A[c]), rhs(eq.b[c]);
    for (int i = 0; i < n; ++i) {
      M[size_t(i) * n + i] += ridge + smooth * double(neighbours[size_t(i)].size());
      for (int j : neighbours[size_t(i)]) M[size_t(i) * n + j] -= smooth;
      rhs[size_t(i)] += ridge;
    }
    // Projected Gauss-Seidel from s = 1 (the current light).
    std::vector<double> x(size_t(n), 1.0);
    int sweep = 0;
    for (; sweep < 2000; ++sweep) {
      double change = 0.0;
      for (int i = 0; i < n; ++i) {
        const double* row = &M[size_t(i) * n];
        double sum = rhs[size_t(i)];
        for (int j = 0; j < n; ++j)
          if (j != i) sum -= row[j] * x[size_t(j)];
        const double diag = std::max(row[i], ridge + 1e-300);
        const double xi = std::clamp(sum / diag, double(settings.min_scale), double(settings.max_scale));
        change = std::max(change, std::abs(xi - x[size_t(i)]));
        x[size_t(i)] = xi;
      }
      if (change < 1e-6) break;
    }
    for (int i = 0; i < n; ++i) s[size_t(i) * 3 + c] = float(x[size_t(i)]);
    if (report) {
      report->after[c] = eq.objective(s, c);
      report->sweeps = std::max(report->sweeps, sweep + 1);
    }
  }
  return s;
}

void scale_texels(const LatlongUpsampler& grid, int width, int height, const std::vector<float>& scales,
                  std::vector<float>& texels) {
  if (texels.size() != size_t(width) * height * 3 || scales.size() != grid.coarse_size())
    throw Error("light solve: texels or scales of the wrong size");
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      int node[4];
      float wt[4];
      grid.taps(x, y, node, wt);
      for (int c = 0; c < 3; ++c) {
        float f = 0.0f;
        for (int k = 0; k < 4; ++k) f += wt[k] * scales[size_t(node[k]) * 3 + c];
        texels[(size_t(y) * width + x) * 3 + c] *= f;
      }
    }
}

}  // namespace ptir
