// The light-albedo balance: one learnt log scale per colour channel that moves
// every albedo up by e^delta and the lat-long environment down by e^-delta at once.
//
// Why: under direct diffuse light the image is unchanged by that move (the
// ambiguity the evaluation's per-channel scale alignment forgives), so per-texel
// and per-Gaussian Adam steps never travel along it -- the recovered albedo's
// overall level stays where it started (0.3; the textured set's truth is ~0.5,
// measured albedo scale 1.7). But the move is not free: interreflections scale
// with albedo^2 and dielectric highlights not at all, so a wrong level makes the
// light between parts and the highlights wrong, and the optimiser bends the
// environment to compensate (the ground's light: the recovered lower hemisphere
// too bright, fed by too little bounce light off a too-dark pedestal). Starting
// the albedo at 0.5 measured +0.9 dB albedo on that set (docs/inversion.md).
// The balance's gradient is the derivative of the loss along the move,
//     dL/d delta_c = sum_i a_ic dL/da_ic  -  sum_t E_tc dL/dE_tc,
// in which the direct diffuse terms cancel exactly (the same path contributes C
// to both sums), so what is left is the interreflection and highlight evidence;
// its own Adam normalises that small signal into steps. The image term only: the
// edge-aware TV on the albedo shrinks with the albedo and would pull the level
// down with it.
#pragma once

#include <array>

#include "ptir/optim/parameters.h"
#include "ptir/scene/scene.h"
#include "ptir/transport/gradients.h"

namespace ptir {

// Whether the balance applies: albedos learnt and a learnt lat-long environment.
bool light_balance_applies(const Parameters& p, const Scene& scene);

// dL/d delta_c for the gradients `g` of the scene's current values (Gaussian
// albedos, mesh base colours when their group is learnt, lat-long texels).
//
// up_step > 0: the derivative along the move a step of that size (in delta)
// actually makes. An albedo near the top of its range cannot rise by e^up_step
// (light_balance_shift clamps it), so its term is weighted by the fraction of the
// rise it can take: (min(a e^h, cap) - a) / (a (e^h - 1)), 1 below cap e^-h.
// Without it a bright channel ran away: its albedos pinned at the cap, the
// interreflection evidence kept asking for brighter albedos, and each step only
// darkened the light (measured: the sample from a 0.5 start, red light / 110 in
// 40 steps). up_step = 0: the plain derivative at the current values.
std::array<double, 3> light_balance_derivative(const Parameters& p, const Scene& scene, const SceneGradients& g,
                                               float up_step = 0.0f);

// Moves the raw parameters by delta (log, per channel): albedos (Gaussians', and
// meshes' when learnt) times e^delta, clamped inside the sigmoid's range; the
// environment's fine texels' log radiance minus delta.
void light_balance_shift(Parameters& p, const std::array<float, 3>& delta);

// The neutral-light constraint (`optimize` without --dataset, docs/relightable.md):
// the shift that makes the learnt environment's per-channel geometric mean grey
// (its mean log radiance equal in every channel), moving the colour difference
// into the albedos. Baked radiance fixes only albedo x light per channel; this
// picks the split a white-balanced capture implies. Zero without an environment.
std::array<float, 3> neutral_light_delta(const Parameters& p);

// The grey-world prior along the balance: P = 1/2 sum_c (nu_c - mean nu)^2 with
// nu_c the log of the learnt albedos' mean in channel c (Gaussians and, when
// learnt, mesh colours). The balance moves nu_c by delta_c, so dP/d delta_c =
// nu_c - mean nu: returned, to be added (times its weight) to the balance's
// gradient. It sees only the albedos' overall colour, never their pattern or
// level, and only where the image term leaves the balance free.
std::array<double, 3> albedo_chroma_prior(const Parameters& p, const Scene& scene);

}  // namespace ptir
