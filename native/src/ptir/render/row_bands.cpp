#include "ptir/render/row_bands.h"

#include <algorithm>
#include <cstring>
#include <string>

#include "ptir/core/error.h"

namespace ptir {

std::vector<RowBand> row_bands(int height, int rank, int size) {
  std::vector<RowBand> out;
  if (height <= 0 || size <= 0) return out;
  const long long count = size == 1 ? 1 : std::min<long long>(height, 4LL * size);  // one process: the whole image
  for (long long b = rank; b < count; b += size) {
    const int y0 = int(height * b / count), y1 = int(height * (b + 1) / count);
    if (y1 > y0) out.push_back({y0, y1 - y0});
  }
  return out;
}

Camera band_camera(const Camera& camera, const RowBand& band) {
  if (band.y0 == 0 && band.h == camera.height) return camera;
  return camera.crop(0, band.y0, camera.width, band.h);
}

Image row_slice(const Image& image, const RowBand& band) {
  Image out(image.width, band.h, image.channel_names);
  const size_t row = size_t(image.width) * size_t(image.channels);
  std::memcpy(out.pixels.data(), image.pixels.data() + size_t(band.y0) * row, sizeof(float) * row * size_t(band.h));
  return out;
}

namespace {

// Channel names for a rank that rendered no band (an image with fewer rows than
// ranks): what the renders give for that channel count.
std::vector<std::string> default_channels(size_t n) {
  static const char* rgba[] = {"R", "G", "B", "A"};
  if (n == 1) return {"Y"};
  std::vector<std::string> names;
  for (size_t c = 0; c < n; ++c) names.push_back(c < 4 ? rgba[c] : "C" + std::to_string(c));
  return names;
}

}  // namespace

Image render_row_bands(const Communicator& comm, const Camera& camera,
                       const std::function<Image(const Camera&, size_t)>& render_band) {
  if (comm.size() == 1) return render_band(camera, 0);
  const std::vector<RowBand> mine = rank_row_bands(camera.height, comm);
  std::vector<float> pixels;
  std::vector<std::string> names;
  for (size_t b = 0; b < mine.size(); ++b) {
    Image part = render_band(band_camera(camera, mine[b]), b);
    if (part.width != camera.width || part.height != mine[b].h)
      throw Error("render_row_bands: a band render has the wrong size");
    names = part.channel_names;
    pixels.insert(pixels.end(), part.pixels.begin(), part.pixels.end());
  }
  std::vector<size_t> counts;
  const std::vector<float> all = comm.allgather(pixels, &counts);
  const size_t pixel_count = size_t(camera.width) * size_t(camera.height);
  if (pixel_count == 0 || all.size() % pixel_count != 0) throw Error("render_row_bands: the ranks' bands do not make an image");
  const size_t channels = all.size() / pixel_count;
  if (names.empty()) names = default_channels(channels);
  if (names.size() != channels) throw Error("render_row_bands: the ranks rendered different channels");
  Image out(camera.width, camera.height, names);
  const size_t row = size_t(camera.width) * channels;
  size_t offset = 0;
  for (int q = 0; q < comm.size(); ++q) {
    size_t used = 0;
    for (const RowBand& band : row_bands(camera.height, q, comm.size())) {
      const size_t n = row * size_t(band.h);
      if (used + n > counts[size_t(q)]) throw Error("render_row_bands: rank " + std::to_string(q) + " sent too few rows");
      std::memcpy(out.pixels.data() + size_t(band.y0) * row, all.data() + offset + used, sizeof(float) * n);
      used += n;
    }
    if (used != counts[size_t(q)]) throw Error("render_row_bands: rank " + std::to_string(q) + " sent too many rows");
    offset += counts[size_t(q)];
  }
  return out;
}

}  // namespace ptir
