// Image textures as Cycles' Image Texture node samples them (UV coordinates,
// Repeat extension, Linear or Closest interpolation), the value a Principled
// BSDF input reads at a surface point. Loading is the scene layer's
// (scene/texture_load.h); this is the texel store and its lookup.
#pragma once

#include <string>
#include <vector>

#include "ptir/math/vec.h"

namespace ptir {

// A surface point's texture coordinates (Blender's UV map: origin at the image's
// bottom-left corner, one repeat per unit).
struct Uv {
  float u = 0.0f, v = 0.0f;
};

enum class TextureInterpolation {
  Linear,   // bilinear between the four nearest texels (Cycles' "Linear": no mipmaps)
  Closest,  // the texel the point falls in (Cycles' "Closest")
};

struct Texture {
  std::string path;  // the file, for messages
  int width = 0, height = 0;
  std::vector<Vec3> texels;  // RGB, bottom row first (Blender's and Cycles' order)
  TextureInterpolation interpolation = TextureInterpolation::Linear;
  // Cycles keeps 8-bit sRGB images as bytes and decodes after filtering (its
  // "compress as sRGB"); other images are linear in `texels` already.
  bool decode_srgb_after_filter = false;

  // The filtered RGB at uv, wrapped (Repeat): what the node's Color output gives.
  Vec3 rgb(Uv uv) const;
};

}  // namespace ptir
