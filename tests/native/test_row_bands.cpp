// Row bands of data-parallel runs (render/row_bands.h): every row dealt exactly once,
// balanced, and a band render is the whole render's rows. The MPI runs themselves are
// tested against one process in tests/python/test_mpi.py.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "ptir/render/aov.h"
#include "ptir/render/render_path.h"
#include "ptir/render/row_bands.h"
#include "ptir/scene/camera.h"
#include "ptir/transport/path_tracer.h"
#include "test_scenes.h"

using namespace ptir;

TEST(RowBands, EveryRowOnceBalancedInterleaved) {
  for (int height = 1; height <= 40; ++height)
    for (int size = 1; size <= 6; ++size) {
      std::vector<int> owner(size_t(height), -1);
      std::vector<int> rows_of(size_t(size), 0);
      int min_h = height, max_h = 0;
      for (int rank = 0; rank < size; ++rank)
        for (const RowBand& b : row_bands(height, rank, size)) {
          ASSERT_GT(b.h, 0);
          min_h = std::min(min_h, b.h);
          max_h = std::max(max_h, b.h);
          for (int y = b.y0; y < b.y0 + b.h; ++y) {
            ASSERT_GE(y, 0);
            ASSERT_LT(y, height);
            EXPECT_EQ(owner[size_t(y)], -1) << "row " << y << " dealt twice (height " << height << ", " << size << " ranks)";
            owner[size_t(y)] = rank;
          }
          rows_of[size_t(rank)] += b.h;
        }
      for (int y = 0; y < height; ++y) EXPECT_GE(owner[size_t(y)], 0) << "row " << y << " dealt to no rank";
      EXPECT_LE(max_h - min_h, 1) << "bands of near-equal height";
      const auto [lo, hi] = std::minmax_element(rows_of.begin(), rows_of.end());
      if (height >= 4 * size) {
        EXPECT_LE(*hi - *lo, 2 * ((height + 4 * size - 1) / (4 * size))) << height << " " << size;
      }
      if (height >= 8 && size == 2) {
        EXPECT_NE(owner[0], owner[size_t(height) - 1]) << "interleaved: top and bottom differ";
      }
    }
  EXPECT_EQ(row_bands(10, 0, 1).size(), 1u);  // one process: one band, the whole image
}

TEST(RowBands, BandRendersAreTheWholeRendersRows) {
  Scene scene;
  *scene.gaussians = test::gaussian_sphere(3000, 0.5f, Vec3(0.6f, 0.4f, 0.3f), 0.4f, 0.0f);
  scene.environment = Environment::constant(Vec3(0.4f, 0.5f, 0.7f), 16, 8);
  PathTracer tracer(scene);
  const float m[16] = {1, 0, 0, 0.1f, 0, 1, 0, 0.0f, 0, 0, 1, 2.5f, 0, 0, 0, 1};
  const Camera cam = make_camera(m, 0.9f, 24, 19);
  IntegratorSettings is;
  is.spp = 4;
  is.max_bounces = 1;
  is.seed = 3;
  AovSettings as;  // pixel centres
  const Image whole_rgb = render_path(tracer, cam, is);
  const Image whole_albedo = render_aov(tracer.accel(), cam, Aov::Albedo, as);
  double max_diff = 0.0;
  for (int size : {2, 3}) {
    for (int rank = 0; rank < size; ++rank)
      for (const RowBand& b : row_bands(cam.height, rank, size)) {
        const Camera bc = band_camera(cam, b);
        ASSERT_EQ(bc.height, b.h);
        const Image rgb = render_path(tracer, bc, is);
        const Image albedo = render_aov(tracer.accel(), bc, Aov::Albedo, as);
        EXPECT_EQ(albedo.pixels, row_slice(whole_albedo, b).pixels) << "pixel centres: bit-identical";
        const Image ref = row_slice(whole_rgb, b);
        for (size_t i = 0; i < rgb.pixels.size(); ++i)
          max_diff = std::max(max_diff, double(std::fabs(rgb.pixels[i] - ref.pixels[i])));
      }
  }
  // Jittered rays: the crop's row offset is one more float rounding (row_bands.h).
  EXPECT_LE(max_diff, 1e-5);
  EXPECT_GT(whole_albedo.at(12, 9, 0), 0.5f);  // the sphere is in view
  // The single process renders the whole camera once.
  int calls = 0;
  Image one = render_row_bands(single_process(), cam, [&](const Camera& c, size_t b) {
    ++calls;
    EXPECT_EQ(c.height, cam.height);
    EXPECT_EQ(b, 0u);
    return render_aov(tracer.accel(), c, Aov::Albedo, as);
  });
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(one.pixels, whole_albedo.pixels);
}
