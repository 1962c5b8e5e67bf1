// The resolution pyramid (optim/view_pyramid.h): the reduced camera sees what
// the full one's f x f blocks see, the reduced targets are the blocks' alpha-
// weighted averages, and the optimiser trains on reduced views for the coarse
// share of its iterations only.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <tbb/global_control.h>

#include "optimizer_fixture.h"
#include "ptir/optim/view_pyramid.h"
#include "ptir/render/render_path.h"

using namespace ptir;
using namespace ptir::test;

TEST(ViewPyramid, FactorIsTheSmallestPowerOfTwoThatFits) {
  EXPECT_EQ(pyramid_factor(128, 128, 16384), 1);
  EXPECT_EQ(pyramid_factor(256, 256, 16384), 2);
  EXPECT_EQ(pyramid_factor(257, 256, 16384), 2);  // 128 x 128 after the remainder's column
  EXPECT_EQ(pyramid_factor(512, 512, 16384), 4);
  EXPECT_EQ(pyramid_factor(1000, 1000, 16384), 8);  // 125^2 = 15625
  EXPECT_EQ(pyramid_factor(1920, 1080, 16384), 16);  // 120 x 67
  EXPECT_EQ(pyramid_factor(512, 512, 0), 1);          // off
  EXPECT_EQ(pyramid_factor(4, 4, 1), 4);              // never below one pixel
}

// Rendered with a 1-pixel box filter, the full view reduced by f is the same
// expectation as the reduced camera's own render (a coarse pixel's box is the
// union of its f x f fine boxes): the reduced intrinsics are exact, a half-pixel
// error in the principal point would show at every edge of the object.
TEST(ViewPyramid, ReducedCameraRendersTheBlocksAverage) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  Scene s;
  s.gaussians = std::make_shared<GaussianField>(truth_field(300));
  s.environment = sky();
  PathTracer tracer(s);
  IntegratorSettings is;
  is.max_bounces = 0;
  is.filter.type = PixelFilterType::Box;
  is.filter.width = 1.0f;
  Camera full = look_at(Vec3(3.0f, -1.0f, 1.0f), Vec3(0.0f), 48, "view");
  full.cx += 0.3f;  // an off-centre principal point, as photos have
  const int f = 4;
  is.spp = 64;
  const Image fine = reduce_image(render_path(tracer, full, is), f);
  is.spp = 64 * f * f;
  is.seed = 99;
  const Image coarse = render_path(tracer, reduce_camera(full, f), is);
  ASSERT_EQ(coarse.width, 12);
  ASSERT_EQ(coarse.height, 12);
  double err = 0.0, edge = 0.0;
  for (size_t i = 0; i < coarse.pixels.size(); ++i) {
    err = std::max(err, double(std::fabs(coarse.pixels[i] - fine.pixels[i])));
    if (i % 4 == 3) edge += double(coarse.pixels[i] > 0.05f && coarse.pixels[i] < 0.95f);
  }
  EXPECT_GT(edge, 8.0) << "the object's silhouette must cross coarse pixels for the test to mean anything";
  EXPECT_LT(err, 0.04) << "largest difference of any channel (alpha included)";
  // The same check fails for a principal point off by half a coarse pixel.
  Camera shifted = reduce_camera(full, f);
  shifted.cx += 0.5f;
  const Image wrong = render_path(tracer, shifted, is);
  double err_wrong = 0.0;
  for (size_t i = 0; i < wrong.pixels.size(); ++i) err_wrong = std::max(err_wrong, double(std::fabs(wrong.pixels[i] - fine.pixels[i])));
  EXPECT_GT(err_wrong, 0.1);
  std::printf("reduced camera against the blocks: largest difference %.4f (shifted half a pixel: %.4f), %d edge pixels\n",
              err, err_wrong, int(edge));
}

TEST(ViewPyramid, TargetsAreAlphaWeightedBlockAverages) {
  TrainingImage t;
  t.has_alpha = true;
  t.rgb = Image(4, 2, {"R", "G", "B"});
  t.alpha = Image(4, 2, {"A"});
  // Block 0: one opaque red pixel, one half-covered blue one, two empty (colour there is junk).
  const float rgb[8][3] = {{1, 0, 0}, {0, 0, 1}, {5, 5, 5}, {0.2f, 0.2f, 0.2f},
                           {7, 7, 7}, {7, 7, 7}, {0.2f, 0.2f, 0.2f}, {0.2f, 0.2f, 0.2f}};
  const float alpha[8] = {1.0f, 0.5f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
  for (int p = 0; p < 8; ++p) {
    for (int c = 0; c < 3; ++c) t.rgb.pixels[size_t(p) * 3 + c] = rgb[p][c];
    t.alpha.pixels[size_t(p)] = alpha[p];
  }
  // Pixels in row-major order: (0,0) (1,0) (2,0) (3,0) / (0,1) (1,1) (2,1) (3,1).
  // Block (0,0) = pixels 0, 1, 4, 5; block (1,0) = pixels 2, 3, 6, 7.
  const TrainingImage r = reduce_training_image(t, 2);
  ASSERT_EQ(r.rgb.width, 2);
  ASSERT_EQ(r.rgb.height, 1);
  EXPECT_TRUE(r.has_alpha);
  EXPECT_FLOAT_EQ(r.alpha.at(0, 0, 0), 1.5f / 4.0f);
  EXPECT_FLOAT_EQ(r.rgb.at(0, 0, 0), 1.0f / 1.5f);  // associated mean over the coverage
  EXPECT_FLOAT_EQ(r.rgb.at(0, 0, 1), 0.0f);
  EXPECT_FLOAT_EQ(r.rgb.at(0, 0, 2), 0.5f / 1.5f);
  EXPECT_FLOAT_EQ(r.alpha.at(1, 0, 0), 0.0f);
  EXPECT_FLOAT_EQ(r.rgb.at(1, 0, 0), (5.0f + 0.6f) / 4.0f);  // nothing covered: the plain mean
}

TEST(ViewPyramid, OptimiserTrainsOnReducedViewsUntilTheFineShare) {
  const OptimizerFixture& fx = fixture();  // 4 views of 24^2
  OptimizerSettings s = small_settings();
  s.iterations = 8;
  s.coarse_pixels = 144;  // 12^2: views reduced by 2
  s.fine_fraction = 0.25f;
  s.views_per_iteration = 0;  // automatic batch: whole views at both levels here
  s.crop_size = -1;
  Optimizer opt(input_scene(fx.n), fx.data, s);
  for (int it = 0; it < 8; ++it) {
    const auto picks = opt.pick_views(it);
    ASSERT_EQ(picks.size(), 1u);
    const int f = it < 6 ? 2 : 1;
    EXPECT_EQ(picks[0].factor, f) << "iteration " << it;
    EXPECT_EQ(picks[0].w, 24 / f);
    EXPECT_EQ(picks[0].h, 24 / f);
  }
  // A coarse and a fine iteration both train (image loss and gradients).
  for (int i = 0; i < 8; ++i) {
    const IterationLog log = opt.step();
    EXPECT_GT(log.image, 0.0) << "iteration " << i;
    EXPECT_TRUE(std::isfinite(log.loss));
  }
  EXPECT_EQ(opt.nonfinite_gradients(), 0u);
}

// The coarse phase's own spp (coarse_spp): the coarse iterations render at it, the fine
// ones at spp; coarse_spp equal to spp is the same run as 0 (bit for bit), and the
// fingerprint names it only where it differs.
TEST(ViewPyramid, CoarsePhaseRendersAtItsOwnSpp) {
  const OptimizerFixture& fx = fixture();
  OptimizerSettings s = small_settings();
  s.iterations = 4;
  s.coarse_pixels = 144;
  s.fine_fraction = 0.5f;  // iterations 0, 1 coarse; 2, 3 fine
  s.views_per_iteration = 0;
  s.crop_size = -1;
  auto losses = [&](int coarse_spp, std::string* pyramid_entry) {
    OptimizerSettings t = s;
    t.coarse_spp = coarse_spp;
    Optimizer opt(input_scene(fx.n), fx.data, t);
    EXPECT_EQ(opt.spp_at(2), coarse_spp > 0 ? coarse_spp : s.integrator.spp);
    EXPECT_EQ(opt.spp_at(1), s.integrator.spp);
    for (const auto& kv : opt.fingerprint())
      if (kv.first == "pyramid") *pyramid_entry = kv.second;
    std::vector<double> l;
    for (int i : {0, 2}) l.push_back(opt.evaluate(i, false).image);  // a coarse and a fine iteration
    return l;
  };
  std::string e0, same, half;
  const auto l0 = losses(0, &e0), lsame = losses(s.integrator.spp, &same), lhalf = losses(s.integrator.spp / 2, &half);
  EXPECT_EQ(l0, lsame);
  EXPECT_EQ(e0, same);
  EXPECT_EQ(e0.find("coarse spp"), std::string::npos) << e0;
  EXPECT_NE(half.find("coarse spp " + std::to_string(s.integrator.spp / 2)), std::string::npos) << half;
  EXPECT_NE(l0[0], lhalf[0]);  // the coarse iteration: other samples
  EXPECT_EQ(l0[1], lhalf[1]);  // the fine one: the same
}

