// Lat-long (equirectangular) environment light in Blender/Cycles orientation,
// with importance sampling over luminance x sin(theta).
//
// Orientation (the Environment Texture node's default mapping, world z up; checked
// against Cycles renders by tests/python/test_light_units.py):
//   lookup direction  d' = Rz(rotation_z) d        (see "Rotation" below)
//   u = 0.5 - atan2(d'.y, d'.x) / (2 pi)           u = 0.5 is +x, 0.25 is +y, 0.75 is -y
//   v = 0.5 + asin(d'.z) / pi                      v = 1 is +z (up), v = 0 is -z
// This is Cycles' direction_to_equirectangular: u = (atan2(y, x) - pi) / (-2 pi),
// v = (acos(z) - pi) / (-pi). Image row 0 (the top row of the file, the first row
// read_image returns) is v = 1: texel (x, y) covers u in [x/W, (x+1)/W) and
// t = 1 - v = theta / pi in [y/H, (y+1)/H), theta measured from +z.
//
// Rotation: rotation_z (radians) is exactly the Z rotation of a Mapping node (type
// Point) between Texture Coordinate > Generated and the Environment Texture's Vector
// input: the texture is looked up at Rz(rotation_z) d, Rz the right-handed rotation
// about +z (x toward y). So a positive rotation turns the visible environment
// clockwise seen from above (toward -y): the feature at texture direction +x appears
// in the world at Rz(-rotation_z) (+x).
//
// Strength: the Background node's strength; radiance = strength * texel (linear RGB).
//
// Lookup is NEAREST (Cycles' "Closest" interpolation), not bilinear: then the
// radiance is constant over each texel, exactly like the piecewise-constant
// sampling density, so light-sampled and BSDF-sampled estimates see the same
// function and the MIS pdf of a direction is exact. (A learnable 128x64 map also
// gets gradients on exactly one texel per lookup: texel_index().)
//
// Sampling: a Distribution2D over texels with weight luminance(texel) * sin(theta at
// the row centre) (never 0 for a non-black texel, since row centres avoid the
// poles); the density in solid angle of a direction in texel (x, y) is
//   pdf(d) = pdf_uv(x, y) / (2 pi^2 sin(theta)),
// theta of the direction itself (the Jacobian of (u, t) -> sphere). At the poles
// (sin theta = 0) pdf() returns 0 and sample() returns an invalid sample (pdf 0),
// a set of measure zero. An all-black map samples (u, t) uniformly.
//
// As an EnvironmentLight: the parameters are the texels (3 per texel, row-major,
// strength not applied); raw = log(texel) (texels are exp(raw), so stay positive).
#pragma once

#include <string>
#include <vector>

#include "ptir/io/image.h"
#include "ptir/lights/distribution.h"
#include "ptir/lights/environment_light.h"
#include "ptir/math/vec.h"

namespace ptir {

struct EnvSample {
  Vec3 wi;         // unit world direction toward the environment
  Vec3 Li;         // radiance arriving from wi (strength applied)
  float pdf = 0;   // solid-angle density; 0 means no sample
  int texel = -1;  // y * width + x of the texel drawn
  bool valid() const { return pdf > 0.0f; }
};

struct EnvUV {
  float u = 0, v = 0;
};

class Environment final : public EnvironmentLight {
 public:
  // A 1x1 black map.
  Environment();
  // From an in-memory image (1 channel = grey, or >= 3 channels: the first three are
  // RGB). Negative texels are clamped to 0; non-finite ones throw Error naming `name`.
  explicit Environment(const Image& image, float strength = 1.0f, float rotation_z = 0.0f,
                       const std::string& name = "environment image");
  // Width x height map of one colour.
  static Environment constant(Vec3 radiance, int width = 1, int height = 1);
  // Loads an EXR/HDR (linear) or any read_image format. Errors name the file.
  static Environment load(const std::string& path, float strength = 1.0f, float rotation_z = 0.0f);

  // Texels: row-major, row 0 = top (v = 1), RGB interleaved, linear, strength NOT applied.
  int width() const { return width_; }
  int height() const { return height_; }
  std::vector<float>& texels() { return texels_; }
  const std::vector<float>& texels() const { return texels_; }
  Vec3 texel(int x, int y) const;
  void set_texel(int x, int y, Vec3 rgb);
  // Rebuilds the sampling distribution; call after the texels change. Until then,
  // sample() and pdf() keep using the previous (mutually consistent) distribution.
  void rebuild_sampling();

  float strength() const { return strength_; }
  void set_strength(float s) { strength_ = s; }
  float rotation_z() const { return rotation_z_; }
  void set_rotation_z(float r);

  // World direction <-> (u, v) (rotation applied; d need not be normalised).
  EnvUV direction_to_uv(Vec3 d) const;
  Vec3 uv_to_direction(float u, float v) const;
  // Texel (y * width + x) a world direction looks up: eval(d) = strength * texel.
  // dL/d(texel) = strength for that texel, 0 for all others (nearest lookup).
  int texel_index(Vec3 d) const;
  void texel_coords(Vec3 d, int* x, int* y) const;

  // Radiance arriving from world direction d (strength applied).
  Vec3 eval(Vec3 d) const override;
  // Importance-sampled direction from two uniforms.
  EnvSample sample(float u0, float u1) const;
  // Solid-angle density of sample() producing d.
  float pdf(Vec3 d) const override;
  // Both from one lookup (the same values as eval and pdf).
  Vec3 eval_pdf(Vec3 d, float* pdf) const override;

  // EnvironmentLight (sample_li uses u0, u1 like sample()).
  std::unique_ptr<EnvironmentLight> clone() const override { return std::make_unique<Environment>(*this); }
  const char* type() const override { return "latlong"; }
  std::string describe() const override;
  EnvLightSample sample_li(float u0, float u1, float u2) const override;
  size_t parameter_count() const override { return texels_.size(); }
  void adjoint(Vec3 d, Vec3 d_Le, float* grad) const override;
  void get_raw(float* raw) const override;
  void set_raw(const float* raw) override;
  void raw_gradient(const float* raw, const float* d_value, float* d_raw) const override;
  Image to_latlong(int w, int h) const override;

 private:
  void local_angles(Vec3 d, double* u, double* t, double* sin_theta) const;
  void cell_of(double u, double t, int* x, int* y) const;  // the texel holding (u, t)
  float pdf_at(int x, int y, double sin_theta) const;       // pdf() of a direction in texel (x, y)
  Vec3 to_world(Vec3 d) const;   // Rz(-rotation) d
  int width_ = 1, height_ = 1;
  std::vector<float> texels_;
  float strength_ = 1.0f;
  float rotation_z_ = 0.0f, cos_rot_ = 1.0f, sin_rot_ = 0.0f;
  Distribution2D distribution_;
};

}  // namespace ptir
