// Float images and their files. EXR/HDR hold linear values; PNG/JPEG are sRGB
// encoded for colour and stored as is for data (normals, depth, masks).
// Alpha (docs/alpha.md): colour with an alpha channel is associated in memory
// and in EXR files (RGB premultiplied by A, as OpenEXR specifies and Cycles
// writes); 8-bit files hold straight colour, as PNG specifies.
#pragma once

#include <string>
#include <vector>

namespace ptir {

struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<std::string> channel_names;  // e.g. R,G,B,A; written to EXR
  std::vector<float> pixels;               // row-major, top row first, interleaved

  Image() = default;
  Image(int w, int h, std::vector<std::string> names)
      : width(w), height(h), channels(int(names.size())), channel_names(std::move(names)),
        pixels(size_t(w) * size_t(h) * size_t(channels), 0.0f) {}
  float& at(int x, int y, int c) { return pixels[(size_t(y) * width + x) * channels + c]; }
  float at(int x, int y, int c) const { return pixels[(size_t(y) * width + x) * channels + c]; }
};

enum class Encoding {
  Colour,          // associated colour: 8-bit files get it un-premultiplied by A, then the sRGB curve (A stays linear)
  StraightColour,  // colour not premultiplied (material colours, averaged over covered samples): the sRGB curve only
  Data,            // values written as they are (clamped to [0, 1] in 8-bit files)
};

// Writes by extension (.exr float, .png/.jpg/.tif 8-bit, .hdr), atomically: a temp
// file in the same folder, then rename. Throws ptir::Error naming the file.
// 8-bit files are written as the values say (OpenImageIO's PNG writer would
// otherwise divide the colour by alpha once more: "oiio:UnassociatedAlpha" is set).
void write_image(const std::string& path, const Image& image, Encoding encoding = Encoding::Colour);

// Reads any format OpenImageIO knows; 8-bit colour is decoded from sRGB, Colour returns associated RGBA
// (a PNG's straight colour decoded, times alpha), Data OIIO's values. Throws ptir::Error naming the file.
// stored_as_bytes (optional) tells whether the file held 8-bit (integer) values
// rather than float or half ones (Cycles filters 8-bit sRGB textures before decoding).
Image read_image(const std::string& path, Encoding encoding = Encoding::Colour, bool* stored_as_bytes = nullptr);

float srgb_to_linear(float c);
float linear_to_srgb(float c);

}  // namespace ptir
