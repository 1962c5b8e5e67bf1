// The facing prior (optim/albedo_facing_prior.h): its value against a closed form
// (an albedo that is exactly a band-1 function of the normal), zero for an albedo
// that does not follow the normal, and its derivative against finite differences.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "ptir/optim/albedo_facing_prior.h"

using namespace ptir;

namespace {

// n Gaussians with normals spread over the sphere (a Fibonacci lattice: even, so the
// regression's basis is well conditioned), unit opacity, given scales.
GaussianField sphere_field(size_t n, std::mt19937* rng = nullptr) {
  GaussianField f;
  std::uniform_real_distribution<float> u(0.5f, 2.0f);
  for (size_t i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / double(n), r = std::sqrt(1.0 - z * z);
    const double phi = double(i) * M_PI * (3.0 - std::sqrt(5.0));
    f.position.push_back(Vec3(0, 0, 0));
    f.normal.push_back(Vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)));
    f.scale.push_back(rng ? Vec3(u(*rng), u(*rng), 1e-3f) : Vec3(1, 1, 1e-3f));
    f.rotation.push_back({1, 0, 0, 0});
    f.opacity.push_back(1.0f);
    f.albedo.push_back(Vec3(0.5f, 0.5f, 0.5f));
  }
  return f;
}

}  // namespace

// a = 0.4 exp(k z): log a = log 0.4 + k z, and the basis' z function is C1 z with
// C1 = sqrt(3 / 4 pi), so the band-1 coefficient is k / C1 and P = 1/2 (k / C1)^2
// per channel (the ridge and the lattice's quadrature off by far less than 1e-3).
TEST(AlbedoFacingPrior, ABand1AlbedoGivesItsClosedForm) {
  GaussianField f = sphere_field(2000);
  const double k[3] = {0.3, -0.2, 0.0}, c1 = std::sqrt(3.0 / (4.0 * M_PI));
  for (size_t i = 0; i < f.size(); ++i)
    for (int c = 0; c < 3; ++c) f.albedo[i][c] = float(0.4 * std::exp(k[c] * f.normal[i].z));
  const FacingPriorResult r = albedo_facing_prior(f, 1.0, nullptr);
  double expected = 0.0;
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(r.correlation[c], std::abs(k[c]) / c1, 2e-3) << "channel " << c;
    expected += 0.5 * (k[c] / c1) * (k[c] / c1);
  }
  EXPECT_NEAR(r.value, expected, 2e-3);
}

// An albedo that varies over the Gaussians but not with their normals (a function
// of the index that is independent of the lattice's facing): the prior is near 0,
// while the same values sorted by height (the top bright) give a large one.
TEST(AlbedoFacingPrior, IsBlindToAPatternThatDoesNotFollowTheNormal) {
  GaussianField f = sphere_field(3000);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.2f, 0.8f);
  std::vector<float> values(f.size());
  for (float& v : values) v = u(rng);
  for (size_t i = 0; i < f.size(); ++i) f.albedo[i] = Vec3(values[i], values[i], values[i]);
  const double shuffled = albedo_facing_prior(f, 1.0, nullptr).value;
  std::sort(values.begin(), values.end());  // the lattice runs from z = 1 down: the top gets the darkest
  for (size_t i = 0; i < f.size(); ++i) f.albedo[i] = Vec3(values[i], values[i], values[i]);
  const double sorted = albedo_facing_prior(f, 1.0, nullptr).value;
  EXPECT_LT(shuffled, 0.01);
  EXPECT_GT(sorted, 100.0 * shuffled);
  EXPECT_GT(sorted, 0.5);
}

// weight x dP/da against central differences of P, on random albedos, scales
// (so the weights differ) and an uneven share of facings.
TEST(AlbedoFacingPrior, DerivativeMatchesFiniteDifferences) {
  std::mt19937 rng(3);
  GaussianField f = sphere_field(300, &rng);
  std::uniform_real_distribution<float> u(0.05f, 0.9f);
  for (size_t i = 0; i < f.size(); ++i) f.albedo[i] = Vec3(u(rng), u(rng), u(rng));
  const double weight = 2.5;
  std::vector<Vec3> grad(f.size(), Vec3(0, 0, 0));
  albedo_facing_prior(f, weight, &grad);
  const double h = 1e-3;
  int checked = 0;
  for (size_t i = 0; i < f.size(); i += 37)
    for (int c = 0; c < 3; ++c) {
      const float a = f.albedo[i][c];
      f.albedo[i][c] = float(a + h);
      const double up = albedo_facing_prior(f, 1.0, nullptr).value;
      f.albedo[i][c] = float(a - h);
      const double down = albedo_facing_prior(f, 1.0, nullptr).value;
      f.albedo[i][c] = a;
      const double fd = weight * (up - down) / (2.0 * h);
      EXPECT_NEAR(grad[i][c], fd, 1e-3 * std::abs(fd) + 1e-6) << "Gaussian " << i << " channel " << c;
      ++checked;
    }
  EXPECT_GE(checked, 24);
}

// Gaussians of one facing (a plane): bands 1-2 cannot be fitted, the ridge keeps the
// solve finite and the prior sees no correlation.
TEST(AlbedoFacingPrior, APlaneGivesNoCorrelation) {
  GaussianField f = sphere_field(50);
  for (size_t i = 0; i < f.size(); ++i) {
    f.normal[i] = Vec3(0, 0, 1);
    f.albedo[i] = Vec3(0.1f + 0.01f * float(i % 7), 0.5f, 0.5f);
  }
  std::vector<Vec3> grad(f.size(), Vec3(0, 0, 0));
  const FacingPriorResult r = albedo_facing_prior(f, 1.0, &grad);
  EXPECT_TRUE(std::isfinite(r.value));
  EXPECT_LT(r.value, 1e-6);
  for (const Vec3& g : grad) EXPECT_TRUE(std::isfinite(g.x) && std::isfinite(g.y) && std::isfinite(g.z));
}
