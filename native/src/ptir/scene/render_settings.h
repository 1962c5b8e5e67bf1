// Settings of the renderers, as plain data: read from scene files and the
// command line, used by the transport layer.
#pragma once

#include <cstdint>
#include <limits>
#include <string>

#include "ptir/material/shading_model.h"
#include "ptir/math/pixel_filter.h"

namespace ptir {

enum class InteractionMode { Aggregate, Discrete };

struct InteractionSettings {
  float tau_g = 0.5f;  // validity threshold on O
  InteractionMode mode = InteractionMode::Aggregate;
};

// How rays spawned at a Gaussian interaction avoid re-hitting the surface they leave.
enum class SelfIntersection {
  BackfaceAware,  // skip back-facing Gaussians (d.n_i > 0) within a range scaled to the interaction's Gaussians
  FixedOffset,    // PTIR code: origin + offset d, skip hits t <= range with n_i.d > 0.1 (world units)
};

// Which lights next-event estimation samples at a vertex.
enum class LightSelection {
  One,  // one light, picked uniformly among the emitters and the environment (Cycles 3.x: every
        // lamp, the world included, has probability 1/N when no mesh emits): one shadow ray
  All,  // a sample of every light: N shadow rays, every light's gradients at every vertex
};

// The names used by scene files, the CLI, the Python module and checkpoints:
// "aggregate"/"discrete", "backface"/"fixed" and "one"/"all". parse_* throws Error
// "<what> must be 'a' or 'b', got 'x'".
const char* interaction_mode_name(InteractionMode m);
InteractionMode parse_interaction_mode(const std::string& name, const std::string& what = "interaction");
const char* self_intersection_name(SelfIntersection s);
SelfIntersection parse_self_intersection(const std::string& name, const std::string& what = "self_intersection");
const char* light_selection_name(LightSelection s);
LightSelection parse_light_selection(const std::string& name, const std::string& what = "light_selection");

struct IntegratorSettings {
  int spp = 32;
  int max_bounces = 2;  // indirect bounces, as Cycles counts them (0: direct light only)
  uint64_t seed = 0;
  BsdfModel brdf = BsdfModel::PrincipledV1;  // surface model of every vertex (scene JSON "brdf", --brdf)
  // Lower bound on the Principled BSDF's specular-lobe sampling probability: 0.1
  // renders with Cycles-like noise; the optimiser uses 1/2 (more specular samples
  // for roughness and highlight gradients). Sampling only: same expectation.
  float min_specular_probability = 0.1f;
  PixelFilter filter;                    // camera-sample offsets (Blender default: Blackman-Harris 1.5 px)
  InteractionSettings interaction;       // aggregate/discrete, tau_g
  bool geometric_criterion = true;       // chi_geom gate; off: every hit with O > 0 is an interaction
  SelfIntersection self_intersection = SelfIntersection::BackfaceAware;
  // Backface-aware: back-facing hits of a spawned ray are skipped within this many
  // times the interaction's Gaussian size (its w-weighted largest scale); beyond
  // it a back-facing splat occludes, as a mesh's back face does. Infinity is the
  // paper's rule (every back-facing hit skipped): it relies on every splat's normal
  // facing out, and a fitted field's hidden splats (under a chin, inside a crease,
  // behind a gap) often do not -- measured on fitted textured sets, 12 % of the
  // rays a mesh blocks went through, and the true materials rendered 31.5 dB from
  // Cycles against 33.5 dB at 8 (2: 33.4, 4: 33.4, 16: 32.1; exact one-per-face
  // splats 29.9-30.0 dB at every range). docs/fidelity.md.
  float self_range_scale = 8.0f;
  float fixed_offset = 0.02f;            // fixed-offset variant: origin offset (world units)
  float fixed_range = 0.08f;             // fixed-offset variant: skip range (world units)
  float min_throughput = 1e-4f;          // end a path when max(beta) falls below this
  LightSelection light_selection = LightSelection::One;  // renders as Cycles; the inversion samples all
  // Russian roulette as Cycles plays it: at every vertex past the first
  // min_light_bounces ones (Cycles' "Min Light Bounces", default 0), the path goes on
  // with probability q = min(sqrt(max_c beta_c), 1) and beta /= q. The emission
  // reaching the vertex is counted either way. Off in the inversion: q depends on
  // the materials, and the replay holds every sampling decision fixed.
  bool russian_roulette = true;
  int min_light_bounces = 0;
  // Indirect light from the captured radiance (the inversion's option): a ray
  // that leaves a vertex and meets the splats ends there with the radiance their
  // SH colour holds (the DC term, what the training photos saw, sRGB-decoded)
  // instead of being shaded with the current materials and light. The bounce
  // light then comes from the data, not from the estimate whose level and light
  // it would otherwise have to follow (transport/field_radiance.h).
  bool indirect_from_field = false;
};

}  // namespace ptir
