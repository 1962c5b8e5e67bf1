// Rows of an image dealt to the ranks of a data-parallel run (core/communicator.h):
// `mpirun -np N ptir render|optimize` splits every image into row bands.
//
// Decision: bands, not tiles or samples. A band is a camera crop (Camera::crop),
// and the path tracer and the AOVs key every random number on the pixel's index in
// the full image, so a band draws the same samples as the whole image and its
// gradient is its rows' share. Pixel-centre renders (AOVs at 1 spp, the
// optimiser's material maps) are bit-identical to a single-process render. A
// jittered camera sample is not quite: its position is (row + 0.5 + offset)
// within the crop and Camera::generate_ray adds the crop's first row, one float
// rounding that the whole image does not make, so a ray may differ in its last
// bit (measured: 3 % of the pixels of a 64x64 8-spp render differ, by <= 4e-7).
// (Computing the sample position in full-image rows in render_path's
// camera_sample would make them bit-identical too.) B = min(height, 4 N) bands of
// near-equal height (one for a single process), band b to rank b mod N
// (interleaved: an object in the middle of the frame is shared by every rank).
#pragma once

#include <functional>
#include <vector>

#include "ptir/core/communicator.h"
#include "ptir/io/image.h"
#include "ptir/scene/camera.h"

namespace ptir {

struct RowBand {
  int y0 = 0, h = 0;  // rows [y0, y0 + h)
};

// The bands rank `rank` of `size` works on, top to bottom.
std::vector<RowBand> row_bands(int height, int rank, int size);
inline std::vector<RowBand> rank_row_bands(int height, const Communicator& comm) {
  return row_bands(height, comm.rank(), comm.size());
}

// The camera restricted to the band (the camera itself for the whole image).
Camera band_camera(const Camera& camera, const RowBand& band);
// Rows [y0, y0 + h) of the image (a copy).
Image row_slice(const Image& image, const RowBand& band);

// Renders this rank's bands, render_band(band camera, index in rank_row_bands),
// each camera.width x band.h, and gathers every rank's: every rank returns the
// whole image. With one rank: render_band(camera, 0), nothing else.
Image render_row_bands(const Communicator& comm, const Camera& camera,
                       const std::function<Image(const Camera&, size_t)>& render_band);

}  // namespace ptir
