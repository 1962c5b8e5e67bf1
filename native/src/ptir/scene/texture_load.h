// Image textures from files (PNG, JPEG, TIFF, EXR, HDR: whatever OpenImageIO
// reads), as Blender's Image Texture node interprets them.
#pragma once

#include <map>
#include <memory>
#include <string>

#include "ptir/material/texture.h"

namespace ptir {

enum class TextureColourSpace {
  Srgb,      // Blender's "sRGB": 8-bit files decoded after filtering, float files when loaded
  NonColor,  // "Non-Color" (also Linear / Raw): values as stored
};

// Loads `path` as an RGB texture (grey images repeat their channel; alpha is not
// used). Throws ptir::Error naming the file when it is missing or not an image.
std::shared_ptr<const Texture> load_texture(const std::string& path, TextureColourSpace space,
                                            TextureInterpolation interpolation);

// One load per (file, colour space, interpolation) for a scene whose materials share images.
class TextureCache {
 public:
  std::shared_ptr<const Texture> get(const std::string& path, TextureColourSpace space, TextureInterpolation interpolation);

 private:
  std::map<std::string, std::shared_ptr<const Texture>> loaded_;
};

}  // namespace ptir
