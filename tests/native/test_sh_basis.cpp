// The splats' SH basis (scene/gaussians.h: sh_basis, GaussianField::sh_colour) up to
// degree 4, as Blender 5.3's splats carry it: orthonormal on the sphere (a wrong
// constant or polynomial shows; the signs, which orthonormality cannot see, are those
// of the 3DGS family's eval_sh, as for degrees 1-3), and a degree-4 PLY (72 f_rest,
// channel-major) read and coloured through it.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/gaussians.h"

using namespace ptir;

// Gram matrix of the 25 basis functions by midpoint quadrature in (cos theta, phi):
// the identity to the rule's error (about 1e-6 here).
TEST(ShBasis, OrthonormalOnTheSphereUpToDegreeFour) {
  constexpr int K = kMaxShCoefficients, nu = 800, nphi = 160;
  static_assert(K == 25, "degree 4");
  double gram[K][K] = {};
  float y[K];
  const double du = 2.0 / nu, dphi = 2.0 * M_PI / nphi, w = du * dphi;
  for (int a = 0; a < nu; ++a) {
    const double u = -1.0 + (a + 0.5) * du, s = std::sqrt(1.0 - u * u);
    for (int b = 0; b < nphi; ++b) {
      const double phi = (b + 0.5) * dphi;
      sh_basis(4, Vec3(float(s * std::cos(phi)), float(s * std::sin(phi)), float(u)), y);
      for (int i = 0; i < K; ++i)
        for (int j = 0; j <= i; ++j) gram[i][j] += w * double(y[i]) * double(y[j]);
    }
  }
  for (int i = 0; i < K; ++i)
    for (int j = 0; j <= i; ++j) EXPECT_NEAR(gram[i][j], i == j ? 1.0 : 0.0, 2e-4) << "Y_" << i << " . Y_" << j;
}

// Lower degrees are the first values of the higher ones (a file of degree d reads the
// same basis as the engine's degree-4 evaluation truncated).
TEST(ShBasis, DegreesArePrefixes) {
  const Vec3 d = normalize(Vec3(0.3f, -0.5f, 0.8f));
  float y4[kMaxShCoefficients], y[kMaxShCoefficients];
  sh_basis(4, d, y4);
  for (int degree = 0; degree < 4; ++degree) {
    sh_basis(degree, d, y);
    for (int k = 0; k < (degree + 1) * (degree + 1); ++k) EXPECT_EQ(y[k], y4[k]) << "degree " << degree;
  }
}

TEST(ShBasis, DegreeFourPlyColour) {
  const std::filesystem::path dir = std::filesystem::path(PTIR_TEST_TMP) / "sh_basis";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "sh4.ply").string();
  {
    std::ofstream f(path, std::ios::binary);
    f << "ply\nformat ascii 1.0\nelement vertex 1\n";
    for (const char* n : {"x", "y", "z", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3",
                          "opacity", "f_dc_0", "f_dc_1", "f_dc_2"})
      f << "property float " << n << "\n";
    for (int j = 0; j < 72; ++j) f << "property float f_rest_" << j << "\n";
    f << "end_header\n0 0 0 0 0 0 1 0 0 0 0 0.1 0.2 0.3";
    for (int j = 0; j < 72; ++j) f << " " << 0.001 * (j + 1);
    f << "\n";
  }
  const GaussianField g = load_gaussians(path);
  ASSERT_EQ(g.sh_degree, 4);
  ASSERT_EQ(g.sh_stride(), 75);
  // Channel-major: sh[k*3 + c] = f_rest_[c*24 + k-1].
  EXPECT_FLOAT_EQ(g.sh[20 * 3 + 2], 0.001f * (2 * 24 + 19 + 1));
  const Vec3 d = normalize(Vec3(-0.2f, 0.6f, 0.4f));
  float y[kMaxShCoefficients];
  sh_basis(4, d, y);
  const Vec3 c = g.sh_colour(0, d);
  for (int ch = 0; ch < 3; ++ch) {
    double expected = 0.5 + y[0] * 0.1 * (ch + 1);
    for (int k = 1; k < 25; ++k) expected += double(y[k]) * 0.001 * (ch * 24 + k);
    EXPECT_NEAR(c[ch], expected, 1e-6) << "channel " << ch;
  }
}
