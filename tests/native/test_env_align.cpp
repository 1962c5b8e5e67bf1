// The baked yaw of optim/env_align.h against the environment's own rotation_z
// (lights/environment.h, itself checked against Blender's Mapping node).
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "ptir/io/image.h"
#include "ptir/lights/environment.h"
#include "ptir/optim/env_align.h"

namespace ptir {
namespace {

Image random_map(int w, int h) {
  Image img(w, h, {"R", "G", "B"});
  uint64_t state = 7;
  for (float& p : img.pixels) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    p = 0.1f + float(state >> 40) / float(1 << 24);
  }
  return img;
}

// Baked at a whole number of columns, the map looked up without rotation gives
// exactly what the original gives with rotation_z = yaw, in every direction.
TEST(EnvAlign, BakedYawEqualsRotationZ) {
  const int w = 32, h = 16;
  const Image img = random_map(w, h);
  for (int cols : {1, 9, 23}) {
    const double yaw = 2.0 * 3.14159265358979323846 * cols / w;
    const Environment turned(img, 1.0f, float(yaw));
    Environment baked(img);
    baked.texels() = rotate_latlong_yaw(baked.texels(), w, h, yaw);
    baked.rebuild_sampling();
    for (int i = 0; i < 200; ++i) {
      // Directions at texel centres (away from the cell borders the float rotation could cross).
      const float u = (float(i % w) + 0.5f) / float(w), v = (float((i * 7) % h) + 0.5f) / float(h);
      const Vec3 d = baked.uv_to_direction(u, v);
      const Vec3 a = turned.eval(d), b = baked.eval(d);
      EXPECT_NEAR(a.x, b.x, 1e-5f) << "cols " << cols << " u " << u << " v " << v;
      EXPECT_NEAR(a.z, b.z, 1e-5f);
    }
  }
}

// Yaw 0 leaves the texels bit for bit.
TEST(EnvAlign, ZeroYawIsTheIdentity) {
  const Image img = random_map(16, 8);
  const Environment env(img);
  EXPECT_EQ(rotate_latlong_yaw(env.texels(), 16, 8, 0.0), env.texels());
}

TEST(EnvAlign, ModeNamesRoundTrip) {
  for (EnvAlignMode m : {EnvAlignMode::Off, EnvAlignMode::Yaw, EnvAlignMode::Auto, EnvAlignMode::Full, EnvAlignMode::Search})
    EXPECT_EQ(parse_env_align_mode(env_align_mode_name(m), "--env-align"), m);
  EXPECT_THROW(parse_env_align_mode("sideways", "--env-align"), std::exception);
}

}  // namespace
}  // namespace ptir
