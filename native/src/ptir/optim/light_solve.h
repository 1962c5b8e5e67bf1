// The light solve: the lat-long environment that best explains the training
// images under the current materials, in closed form, instead of by hundreds of
// noisy Adam steps.
//
// Why: with the materials fixed, every pixel is linear in the environment's
// radiance (render/env_transport.h). Adam learns the light from one view's noisy
// gradient per step, each texel normalised by its own noise; it converges slowly
// along the directions the images pin only weakly (the light's direction and
// shape under diffuse shading) while the albedos, from the end of their warm-up
// on, take up what the light has not explained yet (shading baked into albedo).
// The solve instead takes every view at once and minimises the linearised loss
// exactly.
//
// What is solved: one multiplicative scale per channel at the nodes of a coarse
// lat-long grid (the environment pyramid's coarse level, env_pyramid.h), the
// light becoming Le'(texel) = Le(texel) x (bilinear interpolation of the scales),
// so the fine detail the texels hold is kept. Per channel c, over the pixels p
// inside the masks:
//     min_s  sum_p w_pc (s_v (T_pc . s + e_pc) - y_pc)^2
//            + ridge sum_k (s_k - 1)^2 + smooth sum_(k,j) (s_k - s_j)^2,
//     s_min <= s_k <= s_max,
// T_pc the pixel's transport row (its environment lookups times the current
// radiance, gathered at the nodes), e_pc what the emitters add, s_v the view's
// exposure, y_pc the target, w_pc the square of the loss curve's slope at the
// target (sRGB: dark pixels weigh as the sRGB loss weighs them). The normal
// matrix sum w T^T T is formed from the two independent halves of each pixel's
// samples, (T_a^T T_b + T_b^T T_a) / 2, so the Monte Carlo noise of T does not
// bias it (E[T_a^T T_b] = E[T]^T E[T]); the ridge and smoothness weights are
// relative to the matrix's mean diagonal. Solved by projected Gauss-Seidel.
#pragma once

#include <array>
#include <atomic>
#include <vector>

#include "ptir/core/communicator.h"
#include "ptir/io/image.h"
#include "ptir/lights/environment.h"
#include "ptir/optim/env_pyramid.h"
#include "ptir/scene/dataset.h"
#include "ptir/transport/path_tracer.h"

namespace ptir {

struct LightSolveSettings {
  // When: fractions of the run's iterations before which the light is solved
  // (0: before the first step). Empty: never.
  std::vector<float> at;
  int spp = 8;             // samples per pixel of each view's transport pass (2..16)
  // Weights relative to the normal matrix's mean diagonal: sum (s_k - 1)^2, and
  // sum over grid neighbours (s_k - s_j)^2. The matrix is noisy where the signal is
  // weak (diffuse shading pins only the light's low frequencies, and each pixel's
  // halves see few nodes): on the textured set (128^2, 24 views, 16 x 8 nodes,
  // 8 spp) smoothness 0.01, 1 and 3 sent most nodes to the range's bounds (a few
  // hot spots, the rest black); 10 to 100 gave a smooth light (30: the default).
  float ridge = 1e-2f;
  float smooth = 30.0f;
  float min_scale = 0.02f, max_scale = 50.0f;
  int grid_width = 16;     // the node grid (grid_width x grid_width / 2) without a coarse level
};

// The normal equations of the solve, per channel, over the grid's nodes.
struct LightNormalEquations {
  int width = 0, height = 0;              // node grid
  std::array<std::vector<double>, 3> A;   // nodes x nodes, row-major, symmetric
  std::array<std::vector<double>, 3> b;   // nodes
  std::array<double, 3> yy = {0, 0, 0};   // sum w (y / s_v - e)^2 s_v^2: the objective's constant
  double pixels = 0;                      // pixels added

  LightNormalEquations(int w, int h);
  int nodes() const { return width * height; }
  void add(const LightNormalEquations& o);
  // Sums every rank's equations (Communicator::allreduce_sum, in float).
  void allreduce(const Communicator& comm);
  // The weighted squared misfit at scales s (nodes x 3, RGB interleaved; channel c).
  double objective(const std::vector<float>& s, int c) const;
};

// One view's pixels into `eq`: a transport pass of the tracer's scene at
// `settings` (its spp and seed), the target (linear RGB) and, when given, its
// alpha (pixels count where alpha and the render's coverage reach
// mask_threshold). `exposure`: the view's scale s_v; `srgb`: weight pixels by the
// sRGB curve's slope (else 1). The scene's environment must be a lat-long map of
// the upsampler's fine size.
void add_light_view(const PathTracer& tracer, const Camera& camera, const IntegratorSettings& settings,
                    const Image& target_rgb, const Image* target_alpha, float mask_threshold, float exposure,
                    bool srgb, const LatlongUpsampler& grid, LightNormalEquations& eq,
                    const std::atomic<bool>* cancel = nullptr);

struct LightSolveReport {
  double pixels = 0;
  std::array<double, 3> before = {0, 0, 0}, after = {0, 0, 0};  // objective at s = 1 and at the solution
  int sweeps = 0;
};

// The scales (nodes x 3, RGB interleaved) minimising the objective above.
std::vector<float> solve_light_scales(const LightNormalEquations& eq, const LightSolveSettings& settings,
                                      LightSolveReport* report = nullptr);

// texels (fine, RGB) x the bilinear interpolation of the node scales.
void scale_texels(const LatlongUpsampler& grid, int width, int height, const std::vector<float>& scales,
                  std::vector<float>& texels);

}  // namespace ptir
