// The recovered environment with the photos' detail (lights/env_detail.h): a texel the
// photos saw is their own radiance, any other the learnt coarse map, bilinear.
#include <gtest/gtest.h>

#include "ptir/core/error.h"
#include "ptir/lights/env_detail.h"

using namespace ptir;

TEST(EnvDetail, SeenTexelsAreThePhotosUnseenTheLearntLightBilinear) {
  // A 4 x 2 learnt map whose red is x + 10 y, green 1, blue 2; an 16 x 8 seen map, texels
  // with x < 4 photographed (colour 0.3, 0.4, 0.5 + x / 100), the rest not.
  Image learnt(4, 2, {"R", "G", "B"});
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) learnt.at(x, y, 0) = float(x + 10 * y), learnt.at(x, y, 1) = 1.0f, learnt.at(x, y, 2) = 2.0f;
  Image seen(16, 8, {"R", "G", "B", "seen"});
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 4; ++x)
      seen.at(x, y, 0) = 0.3f, seen.at(x, y, 1) = 0.4f, seen.at(x, y, 2) = 0.5f + float(x) / 100.0f, seen.at(x, y, 3) = 1.0f;
  const Image out = env_with_detail(learnt, seen);
  ASSERT_EQ(out.width, 16);
  ASSERT_EQ(out.height, 8);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 4; ++x) {
      EXPECT_FLOAT_EQ(out.at(x, y, 0), 0.3f);
      EXPECT_FLOAT_EQ(out.at(x, y, 2), 0.5f + float(x) / 100.0f);
    }
  // Fine texel (6, 2): centre at coarse (1.625, 0.625), texel centres at +0.5 -> 0.125 of the way from
  // column 1 to 2 and from row 0 to 1: red = 1.125 + 10 * 0.125.
  EXPECT_NEAR(out.at(6, 2, 0), 1.125f + 1.25f, 1e-5f);
  EXPECT_NEAR(out.at(6, 2, 1), 1.0f, 1e-6f);
  EXPECT_NEAR(out.at(6, 2, 2), 2.0f, 1e-6f);
  // The top rows clamp to row 0: fine (10, 0) at coarse (2.625, 0.125) -> row 0, red 2.125.
  EXPECT_NEAR(out.at(10, 0, 0), 2.125f, 1e-5f);
  // A seen map without its 4th channel is refused.
  EXPECT_THROW(env_with_detail(learnt, Image(16, 8, {"R", "G", "B"})), Error);
}
