#include "ptir/io/image.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <unistd.h>

#include "ptir/core/error.h"

namespace ptir {

namespace fs = std::filesystem;

float srgb_to_linear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

float linear_to_srgb(float c) {
  c = std::clamp(c, 0.0f, 1.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

bool is_float_format(const std::string& ext) { return ext == ".exr" || ext == ".hdr" || ext == ".pfm"; }

bool is_alpha(const std::string& name) { return name == "A" || name == "a" || name == "alpha"; }

}  // namespace

void write_image(const std::string& path, const Image& image, Encoding encoding) {
  if (image.width <= 0 || image.height <= 0 || image.channels <= 0)
    throw Error(path, "cannot write an empty image");
  std::string ext = lower_extension(path);
  if (ext.empty()) throw Error(path, "output file needs an extension (.exr or .png)");
  bool floating = is_float_format(ext);

  OIIO::ImageSpec spec(image.width, image.height, image.channels, floating ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8);
  spec.channelnames = image.channel_names;
  spec.alpha_channel = -1;
  for (int c = 0; c < image.channels; ++c)
    if (is_alpha(image.channel_names[c])) spec.alpha_channel = c;
  if (ext == ".exr") spec.attribute("compression", "zip");

  // 8-bit files: sRGB curve on colour channels, plain clamp on data and alpha.
  std::vector<float> out = image.pixels;
  if (!floating) {
    for (size_t i = 0; i < out.size(); ++i) {
      int c = int(i % size_t(image.channels));
      bool colour = encoding == Encoding::Colour && !is_alpha(image.channel_names[c]);
      out[i] = colour ? linear_to_srgb(out[i]) : std::clamp(out[i], 0.0f, 1.0f);
    }
  }

  // Temp file keeps the extension so OpenImageIO picks the right writer.
  fs::path target(path);
  fs::path tmp = target.parent_path() / ("." + target.stem().string() + ".tmp" + std::to_string(getpid()) + ext);
  {
    auto writer = OIIO::ImageOutput::create(tmp.string());
    if (!writer) throw Error(path, "no image writer for '" + ext + "': " + OIIO::geterror());
    if (!writer->open(tmp.string(), spec)) throw Error(path, "cannot create file: " + writer->geterror());
    bool ok = writer->write_image(OIIO::TypeDesc::FLOAT, out.data());
    std::string err = ok ? "" : writer->geterror();
    if (!writer->close() || !ok) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw Error(path, "writing failed: " + err);
    }
  }
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error(path, "cannot move the finished file into place: " + ec.message());
  }
}

Image read_image(const std::string& path, Encoding encoding) {
  if (!fs::exists(path)) throw Error(path, "file not found");
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw Error(path, "cannot read image: " + OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) throw Error(path, "image has no pixels");
  Image image(spec.width, spec.height, spec.channelnames);
  if (int(image.channel_names.size()) != spec.nchannels) image = Image(spec.width, spec.height, std::vector<std::string>(spec.nchannels, "?"));
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.pixels.data()))
    throw Error(path, "cannot decode image data: " + in->geterror());
  bool eight_bit = !is_float_format(lower_extension(path)) && spec.format.basetype != OIIO::TypeDesc::FLOAT &&
                   spec.format.basetype != OIIO::TypeDesc::HALF;
  if (eight_bit && encoding == Encoding::Colour) {
    for (size_t i = 0; i < image.pixels.size(); ++i) {
      int c = int(i % size_t(image.channels));
      if (c != spec.alpha_channel) image.pixels[i] = srgb_to_linear(image.pixels[i]);
    }
  }
  for (float v : image.pixels)
    if (!std::isfinite(v)) throw Error(path, "image contains NaN or infinite values");
  return image;
}

}  // namespace ptir
