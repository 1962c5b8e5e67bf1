// TensoIR's albedo protocol (eval/tensoir_albedo.h) and the environment score
// (eval/env_score.h) against values worked out by hand.
#include <gtest/gtest.h>

#include <cmath>

#include "ptir/eval/env_score.h"
#include "ptir/eval/tensoir_albedo.h"

using namespace ptir;
using namespace ptir::eval;

namespace {

Image constant(int w, int h, std::vector<std::string> names, std::vector<float> v) {
  Image img(w, h, names);
  for (size_t p = 0; p < size_t(w) * h; ++p)
    for (int c = 0; c < img.channels; ++c) img.pixels[p * img.channels + c] = v[c];
  return img;
}

}  // namespace

TEST(TensoirAlbedo, ScaleIsMedianOverAlphaNonZeroAndBackgroundIsWhite) {
  // 4x1 image: pixels 0, 1 covered (alpha 1), 2 half covered, 3 background.
  Image gt = constant(4, 1, {"R", "G", "B"}, {0.4f, 0.4f, 0.4f});
  Image pred = constant(4, 1, {"R", "G", "B", "A"}, {0.2f, 0.2f, 0.2f, 1.0f});
  Image alpha = constant(4, 1, {"A"}, {1.0f});
  alpha.pixels[2] = 0.5f;
  alpha.pixels[3] = 0.0f;
  pred.pixels[2 * 4 + 3] = 0.5f;  // our coverage there too
  TensoirAlbedoScore score(1);
  score.add_ratios(0, gt, pred, alpha);
  const auto s = score.scale();
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(s[c], 2.0, 1e-6);
  // With the scale every pixel matches exactly: 100 dB.
  score.add_error(gt, pred, alpha, s);
  EXPECT_EQ(score.psnr(), 100.0);
}

TEST(TensoirAlbedo, PsnrIsOneMseOverAllPixelsInGamma22) {
  // One covered pixel of 2: gt 0.25, ours 0.5 after a forced scale of 1, background white in both.
  Image gt = constant(2, 1, {"R", "G", "B"}, {0.25f, 0.25f, 0.25f});
  Image pred = constant(2, 1, {"R", "G", "B"}, {0.5f, 0.5f, 0.5f});
  Image alpha = constant(2, 1, {"A"}, {0.0f});
  alpha.pixels[0] = 1.0f;
  TensoirAlbedoScore score(1);
  score.add_error(gt, pred, alpha, {1.0, 1.0, 1.0});
  const double d = std::pow(0.5, 1 / 2.2) - std::pow(0.25, 1 / 2.2);
  EXPECT_NEAR(score.psnr(), -10.0 * std::log10(d * d / 2.0), 1e-4);  // the background pixel counts, error 0
}

TEST(TensoirAlbedo, SamplesTwentyViewsAtIntervalNOver20) {
  TensoirAlbedoScore score(40);  // interval 2: views 0, 2, ..., 38 count
  Image alpha = constant(1, 1, {"A"}, {1.0f});
  Image pred = constant(1, 1, {"R", "G", "B"}, {1.0f, 1.0f, 1.0f});
  for (size_t v = 0; v < 40; ++v) {
    Image gt = constant(1, 1, {"R", "G", "B"}, {v % 2 ? 9.0f : 0.5f, 0.5f, 0.5f});  // odd views would pull to 9
    score.add_ratios(v, gt, pred, alpha);
  }
  EXPECT_NEAR(score.scale()[0], 0.5, 1e-6);
}

TEST(EnvScore, ScaledCopyIsPerfectAfterAlignment) {
  Image gt(16, 8, {"R", "G", "B"});
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x)
      for (int c = 0; c < 3; ++c) gt.pixels[(size_t(y) * 16 + x) * 3 + c] = 0.2f + 0.1f * float(x % 5) + 0.3f * float(c);
  Image ours = gt;
  const float k[3] = {0.5f, 2.0f, 1.25f};
  for (size_t p = 0; p < 16 * 8; ++p)
    for (int c = 0; c < 3; ++c) ours.pixels[p * 3 + c] *= k[c];
  const EnvScore s = score_environment(ours, gt);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(s.scale[c], 1.0 / k[c], 1e-5);
  EXPECT_GT(s.psnr, 60.0);
  EXPECT_GT(s.psnr_upper, 60.0);
  EXPECT_EQ(s.sheet.height, 3 * 8 * (512 / 16) + 4 * 2);  // three rows of tiles, 2-px gaps
}

TEST(EnvScore, ErrorOnlyInTheLowerHalfLeavesTheSkyPerfect) {
  Image gt = constant(16, 8, {"R", "G", "B"}, {0.5f, 0.5f, 0.5f});
  Image ours = gt;
  // Lower half darker (0.25) but keep the solid-angle mean equal by no scaling: compute expected.
  for (int y = 4; y < 8; ++y)
    for (int x = 0; x < 16; ++x)
      for (int c = 0; c < 3; ++c) ours.pixels[(size_t(y) * 16 + x) * 3 + c] = 0.25f;
  const EnvScore s = score_environment(ours, gt);
  // The energy match scales ours by 0.5 / 0.375 = 4/3 (both halves hold equal solid angle).
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(s.scale[c], 4.0 / 3.0, 1e-4);
  auto display = [](float x) { return linear_to_srgb(x / (1.0f + x)); };
  const double d_up = display(0.5f * 4.0f / 3.0f) - display(0.5f), d_low = display(0.25f * 4.0f / 3.0f) - display(0.5f);
  EXPECT_NEAR(s.psnr_upper, -10.0 * std::log10(d_up * d_up), 1e-3);
  EXPECT_NEAR(s.psnr, -10.0 * std::log10(0.5 * (d_up * d_up + d_low * d_low)), 1e-3);
}
