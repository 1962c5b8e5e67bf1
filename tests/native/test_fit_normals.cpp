// The geometry stage's normal handling (optim/geometry_fit.h, optim/pseudo_normals.h):
// the per-hit normal loss's gradient, its outlier threshold, and the re-orientation
// of learnt normals toward the cameras that see them.
#include <gtest/gtest.h>

#include <cmath>

#include "ptir/optim/geometry_fit.h"
#include "ptir/optim/pseudo_normals.h"
#include "test_scenes.h"

using namespace ptir;

namespace {

// Two pixels with a pseudo-normal, one without.
struct NormalPixels {
  Image nsum{3, 1, {"X", "Y", "Z"}}, pseudo{3, 1, {"X", "Y", "Z", "A"}};
  NormalPixels() {
    const Vec3 s[3] = {Vec3(0, 0, 0.8f), Vec3(0.5f, 0, 0.5f), Vec3(0, 1, 0)};
    for (int x = 0; x < 3; ++x)
      for (int c = 0; c < 3; ++c) nsum.at(x, 0, c) = s[x][c];
    for (int x = 0; x < 2; ++x) pseudo.at(x, 0, 2) = 1.0f, pseudo.at(x, 0, 3) = 1.0f;  // p = +z
  }
};

}  // namespace

TEST(FitNormals, PerHitGradientIsMinusThePseudoNormal) {
  // sum_i w_i (1 - n_i . p) with the weights held: dL/dNsum = -p (times weight / count).
  NormalPixels px;
  Image d;
  const double value = normal_consistency(px.nsum, px.pseudo, 0.5f, &d, /*per_hit=*/true);
  EXPECT_NEAR(value, 0.5 * ((1.0 - 1.0) + (1.0 - std::sqrt(0.5))), 1e-6);  // the blend's mean, as reported
  for (int x = 0; x < 2; ++x) {
    EXPECT_FLOAT_EQ(d.at(x, 0, 2), -0.25f);
    EXPECT_FLOAT_EQ(d.at(x, 0, 0), 0.0f);
  }
  for (int c = 0; c < 3; ++c) EXPECT_EQ(d.at(2, 0, c), 0.0f);  // no pseudo-normal: no gradient
}

TEST(FitNormals, OutlierThresholdSupervisesOnlyFarPixels) {
  NormalPixels px;
  Image d;
  // 30 degrees: pixel 0 agrees (0 degrees) and gets nothing, pixel 1 (45 degrees) is supervised.
  normal_consistency(px.nsum, px.pseudo, 0.5f, &d, true, std::cos(30.0f * 3.14159265f / 180.0f));
  EXPECT_EQ(d.at(0, 0, 2), 0.0f);
  EXPECT_FLOAT_EQ(d.at(1, 0, 2), -0.25f);
  // The blend's gradient obeys the same threshold.
  normal_consistency(px.nsum, px.pseudo, 0.5f, &d, false, std::cos(30.0f * 3.14159265f / 180.0f));
  EXPECT_EQ(d.at(0, 0, 0), 0.0f);
  EXPECT_GT(d.at(1, 0, 0), 0.0f);  // -(p - (n.p) n) / |s| = (0.5, 0, -0.5) / |s| times the weight for n = (1, 0, 1)/sqrt 2
}

TEST(FitNormals, ReorientFacesTheCamerasAndKeepsUnseenSigns) {
  // A row of flat discs in the plane z = 0 seen from +z, and one far outside the view.
  GaussianField f;
  for (int i = 0; i < 5; ++i) test::add_gaussian(f, Vec3(-0.4f + 0.2f * i, 0, 0), Vec3(0.15f, 0.15f, 0.001f), {1, 0, 0, 0}, 0.9f);
  test::add_gaussian(f, Vec3(50, 0, 0), Vec3(0.15f, 0.15f, 0.001f), {1, 0, 0, 0}, 0.9f);
  for (size_t i : {1u, 3u, 5u}) f.normal[i] = -f.normal[i];  // facing away (5: unseen)
  const float c2w[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 3.0f, 0, 0, 0, 1};
  const std::vector<Camera> cams{make_camera(c2w, 0.6f, 32, 32)};
  f.normals_from_file = true;  // learnt normals are re-voted whatever their origin
  const std::vector<size_t> flipped = reorient_fit_normals(f, cams, AccelSettings{});
  EXPECT_EQ(flipped, (std::vector<size_t>{1, 3}));
  for (int i = 0; i < 5; ++i) EXPECT_GT(f.normal[i].z, 0.99f) << i;
  EXPECT_LT(f.normal[5].z, -0.99f);  // unseen: its sign stays
  EXPECT_TRUE(f.normals_from_file);
}
