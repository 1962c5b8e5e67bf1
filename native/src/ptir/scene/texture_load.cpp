#include "ptir/scene/texture_load.h"

#include "ptir/core/error.h"
#include "ptir/io/image.h"

namespace ptir {

std::shared_ptr<const Texture> load_texture(const std::string& path, TextureColourSpace space,
                                            TextureInterpolation interpolation) {
  bool bytes = false;
  const Image image = read_image(path, Encoding::Data, &bytes);  // throws naming the file
  auto tex = std::make_shared<Texture>();
  tex->path = path;
  tex->width = image.width;
  tex->height = image.height;
  tex->interpolation = interpolation;
  // Blender's colour spaces: an sRGB 8-bit image is filtered in sRGB and decoded
  // afterwards (Cycles' "compress as sRGB"); Non-Color values are used as stored.
  tex->decode_srgb_after_filter = space == TextureColourSpace::Srgb && bytes;
  // Grey and grey+alpha files repeat their one channel; alpha (a fourth, or second, channel) is not used.
  const int c = image.channels;
  const int rgb = c >= 3 ? 3 : 1;
  tex->texels.resize(size_t(image.width) * size_t(image.height));
  for (int y = 0; y < image.height; ++y) {
    const int row = image.height - 1 - y;  // files are stored top row first; UV v = 0 is the bottom
    for (int x = 0; x < image.width; ++x) {
      const float r = image.at(x, row, 0);
      tex->texels[size_t(y) * size_t(image.width) + size_t(x)] =
          rgb == 3 ? Vec3(r, image.at(x, row, 1), image.at(x, row, 2)) : Vec3(r);
    }
  }
  // An sRGB float image (an EXR tagged sRGB in Blender) is decoded when it loads, as Cycles converts it.
  if (space == TextureColourSpace::Srgb && !bytes)
    for (Vec3& t : tex->texels) t = Vec3(srgb_to_linear(t.x), srgb_to_linear(t.y), srgb_to_linear(t.z));
  if (tex->texels.empty()) throw Error(path, "texture has no pixels");
  return tex;
}

std::shared_ptr<const Texture> TextureCache::get(const std::string& path, TextureColourSpace space,
                                                 TextureInterpolation interpolation) {
  const std::string key = path + (space == TextureColourSpace::Srgb ? "|srgb" : "|data") +
                          (interpolation == TextureInterpolation::Linear ? "|linear" : "|closest");
  auto it = loaded_.find(key);
  if (it != loaded_.end()) return it->second;
  return loaded_[key] = load_texture(path, space, interpolation);
}

}  // namespace ptir
