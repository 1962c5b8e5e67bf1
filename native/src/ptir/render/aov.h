// Arbitrary output variables of the primary hit: coverage, depth, normal and the
// material channels of the equivalent surface interaction, and an SH-colour
// preview composited front to back. Meshes are opaque and end the walk.
#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include "ptir/accel/scene_accel.h"
#include "ptir/core/render_control.h"
#include "ptir/io/image.h"
#include "ptir/math/pixel_filter.h"
#include "ptir/scene/camera.h"
#include "ptir/transport/interaction.h"

namespace ptir {

// DiffuseColor is Blender's Diffuse Color pass: the diffuse closure's weight,
// base colour x (1 - metallic) for the Principled BSDF (what a dataset's albedo
// ground truth is); Albedo is the base colour itself.
enum class Aov { Opacity, Depth, Normal, Albedo, Roughness, Metallic, Preview, DiffuseColor };

// "opacity", "depth", ... ; throws ptir::Error listing the valid names.
Aov parse_aov(const std::string& name);
const char* aov_name(Aov aov);
// Colour AOVs get the sRGB curve in 8-bit files; data AOVs are written as values.
Encoding aov_encoding(Aov aov);

struct AovSettings {
  InteractionSettings interaction;
  int spp = 1;        // 1: one ray through each pixel centre; more: offsets drawn from the filter, averaged
  PixelFilter filter;  // as the path renders (Blender default: Blackman-Harris 1.5 px)
  uint64_t seed = 0;  // jitter and discrete picks
};

// AOV of one primary ray.
struct AovSample {
  float opacity = 0.0f;  // Gaussian O plus the transmitted mesh coverage
  bool hit = false;      // a valid Gaussian interaction or a mesh
  float depth = 0.0f;    // ray distance of the interaction
  Vec3 normal, albedo;
  float roughness = 0.0f, metallic = 0.0f;
  Vec3 preview;          // SH colour composited, plus the transmitted mesh colour
};

// What a primary walk handed to its interaction builder, in order, and how it
// ended: all its AovSample depends on (with the ray and pick key), so an adjoint
// can rebuild the interaction from it without tracing (material_maps.h).
struct AovWalk {
  std::vector<GaussianHit> hits;
  WalkEnd end;
};

// The preview colour (SH evaluated per hit) is only computed when with_preview is set.
// walk (optional) receives the walk's hits (cleared first) and end.
AovSample trace_aov(const SceneAccel& accel, const Ray& ray, const AovSettings& settings, uint64_t pick_key,
                    bool with_preview, TraceStats* stats = nullptr, AovWalk* walk = nullptr);

// trace_aov for n <= SceneAccel::kMaxPacket coherent rays traced together (camera
// rays of neighbouring pixels): samples[i] is trace_aov(rays[i], pick_keys[i]).
void trace_aov_packet(const SceneAccel& accel, const Ray* rays, int n, const AovSettings& settings,
                      const uint64_t* pick_keys, bool with_preview, AovSample* samples, TraceStats* stats = nullptr,
                      AovWalk* walks = nullptr);

// Image layouts: opacity -> A; depth -> Z, A; normal -> X, Y, Z, A (world space);
// albedo/preview -> R, G, B, A; roughness/metallic -> Y, A. Background pixels are
// zero with A = 0. All values are linear; see aov_for_8bit for PNG output.
//
// Preview: 3DGS trainers fit SH colours to sRGB photos, so an SH colour is a
// display (sRGB) value. The preview composites in that space, as a splat
// rasteriser does (a mesh behind contributes its shaded base colour, encoded),
// and converts the result to linear so EXR holds linear values like every AOV.
Image render_aov(const SceneAccel& accel, const Camera& camera, Aov aov, const AovSettings& settings,
                 const RenderControl& control = {}, TraceStats* stats = nullptr);

// The image to write into an 8-bit file, where values must fit [0, 1]: normals
// become 0.5 + 0.5 n, depth is divided by the largest depth in the image (the
// scale is stored in the returned image's name, e.g. "depth/8.25"); other AOVs are
// unchanged (colour AOVs get the sRGB curve from write_image).
Image aov_for_8bit(Aov aov, const Image& image, float* depth_scale = nullptr);

}  // namespace ptir
