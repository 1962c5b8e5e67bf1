#include "ptir/io/image.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/io/exr_header.h"
#include "ptir/io/input_file.h"
#include "ptir/io/memory_budget.h"

namespace ptir {

using io::check_exr_header;
using io::check_regular_file;
using io::write_atomic;
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

  // 8-bit files: straight colour (associated colour divided by its alpha), the sRGB
  // curve on colour channels, plain clamp on data and alpha; handed to the writer as
  // unassociated, so that it stores them as they are.
  std::vector<float> out = image.pixels;
  if (!floating) {
    if (spec.alpha_channel >= 0) spec.attribute("oiio:UnassociatedAlpha", 1);
    const size_t nc = size_t(image.channels);
    for (size_t i = 0; i < out.size(); ++i) {
      const int c = int(i % nc);
      const bool colour = encoding != Encoding::Data && c != spec.alpha_channel;
      if (!colour) {
        out[i] = std::clamp(out[i], 0.0f, 1.0f);
        continue;
      }
      float v = out[i];
      if (encoding == Encoding::Colour && spec.alpha_channel >= 0) {
        const float a = image.pixels[i - size_t(c) + size_t(spec.alpha_channel)];
        v = a > 0.0f ? v / a : 0.0f;
      }
      out[i] = linear_to_srgb(v);
    }
  }

  // The temp file keeps the extension (atomic_file.h), so OpenImageIO picks the right writer.
  write_atomic(path, [&](const std::string& tmp) {
    auto writer = OIIO::ImageOutput::create(tmp);
    if (!writer) throw Error(path, "no image writer for '" + ext + "': " + OIIO::geterror());
    if (!writer->open(tmp, spec)) throw Error(path, "cannot create file: " + writer->geterror());
    bool ok = writer->write_image(OIIO::TypeDesc::FLOAT, out.data());
    std::string err = ok ? "" : writer->geterror();
    if (!writer->close() || !ok) throw Error(path, "writing failed: " + (err.empty() ? writer->geterror() : err));
    // Checked to its last byte: the writers do not all report a full disk (an
    // EXR came out as 0 bytes with success), so the file is decoded back whole.
    // Read in bands of 64 rows: a bounded copy, whatever the size.
    auto check = OIIO::ImageInput::open(tmp);
    bool whole = check && check->spec().width == image.width && check->spec().height == image.height &&
                 check->spec().nchannels == image.channels;
    std::vector<float> band(size_t(image.width) * size_t(image.channels) * 64);
    for (int y = 0; whole && y < image.height; y += 64)
      whole = check->read_scanlines(0, 0, y, std::min(y + 64, image.height), 0, 0, image.channels,
                                    OIIO::TypeDesc::FLOAT, band.data()) &&
              !check->has_error();
    if (!whole) throw Error(path, "writing failed: the written file does not read back whole (is the disk full?)");
  });
}

Image read_image(const std::string& path, Encoding encoding, bool* stored_as_bytes) {
  // "file not found"; a FIFO or a device is refused before OIIO blocks on it; an
  // EXR header's attributes must fit in the file before OpenEXR allocates them.
  check_exr_header(path, check_regular_file(path, "image"));
  // Colour: a file's unassociated alpha (PNG's) is read as stored and associated below, in linear.
  OIIO::ImageSpec config;
  if (encoding != Encoding::Data) config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) throw Error(path, "cannot read image: " + OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) throw Error(path, "image has no pixels");
  // The header's size is checked before anything is allocated (a 60-byte file may declare 10^10 pixels).
  io::check_decode_size(path, spec.width, spec.height, spec.nchannels);
  Image image(spec.width, spec.height, spec.channelnames);
  if (int(image.channel_names.size()) != spec.nchannels) image = Image(spec.width, spec.height, std::vector<std::string>(spec.nchannels, "?"));
  // A short or corrupt file is an error, never an image with its tail missing:
  // OIIO reports a cut PNG or EXR through the return value, but a cut JPEG or
  // TIFF (decoded as far as it goes) only through has_error().
  const bool ok = in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.pixels.data());
  if (!ok || in->has_error()) {
    std::string why = in->geterror();
    if (why.empty()) why = OIIO::geterror();
    throw Error(path, "cannot decode image data (is the file truncated or corrupt?): " + (why.empty() ? "read failed" : why));
  }
  bool eight_bit = !is_float_format(lower_extension(path)) && spec.format.basetype != OIIO::TypeDesc::FLOAT &&
                   spec.format.basetype != OIIO::TypeDesc::HALF;
  if (stored_as_bytes)
    *stored_as_bytes = spec.format.basetype == OIIO::TypeDesc::UINT8 || spec.format.basetype == OIIO::TypeDesc::INT8;
  if (eight_bit && encoding != Encoding::Data) {
    for (size_t i = 0; i < image.pixels.size(); ++i) {
      int c = int(i % size_t(image.channels));
      if (c != spec.alpha_channel) image.pixels[i] = srgb_to_linear(image.pixels[i]);
    }
  }
  const bool straight_file = spec.alpha_channel >= 0 && spec.get_int_attribute("oiio:UnassociatedAlpha", 0) != 0;
  if (straight_file && encoding == Encoding::Colour) {
    const size_t nc = size_t(image.channels);
    for (size_t i = 0; i < image.pixels.size(); ++i)
      if (int(i % nc) != spec.alpha_channel) image.pixels[i] *= image.pixels[i - i % nc + size_t(spec.alpha_channel)];
  }
  for (float v : image.pixels)
    if (!std::isfinite(v)) throw Error(path, "image contains NaN or infinite values");
  return image;
}

}  // namespace ptir
