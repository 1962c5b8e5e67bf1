// The closed-form peak and response of one Gaussian along a ray, checked against
// brute-force sampling of the Gaussian density along that ray (double precision,
// covariance built and inverted directly, independent of the unit-space form).
#include <gtest/gtest.h>

#include <random>

#include "ptir/accel/gaussian_response.h"
#include "ptir/accel/scene_accel.h"
#include "test_scenes.h"

using namespace ptir;

namespace {

struct Mat3d {
  double m[3][3];
};

// Sigma^-1 = R S^-2 R^T in double precision.
Mat3d inverse_covariance(const GaussianField& f, size_t i) {
  Mat3 r = f.rotation_matrix(i);
  Vec3 s = f.scale[i];
  Mat3d inv{};
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double sum = 0;
      for (int k = 0; k < 3; ++k) sum += double(r.m[a][k]) * double(r.m[b][k]) / (double(s[k]) * double(s[k]));
      inv.m[a][b] = sum;
    }
  return inv;
}

double density(const Mat3d& inv, Vec3 mu, double x, double y, double z) {
  double d[3] = {x - mu.x, y - mu.y, z - mu.z};
  double q = 0;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) q += d[a] * inv.m[a][b] * d[b];
  return std::exp(-0.5 * q);
}

}  // namespace

TEST(GaussianResponse, PeakAndResponseMatchBruteForceSampling) {
  GaussianField f = test::random_field(40, 7, 0.05f, 0.5f);
  auto sorted = make_trace_data(f);
  // The trace data is stored in spatial order; index it by Gaussian id here.
  std::vector<GaussianTraceData> data(sorted.size());
  for (const auto& g : sorted) data[g.id] = g;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  int checked = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    Mat3d inv = inverse_covariance(f, i);
    for (int trial = 0; trial < 5; ++trial) {
      // A ray passing near the Gaussian from a random origin.
      Vec3 o = f.position[i] + Vec3(u(rng), u(rng), u(rng)) * 3.0f;
      Vec3 target = f.position[i] + Vec3(u(rng), u(rng), u(rng)) * 0.3f;
      Vec3 d = normalize(target - o);
      PeakResponse p = peak_response(data[i], o, d);
      // Brute force: dense samples around the peak, then the best sample.
      double best_t = 0, best_rho = -1;
      const int n = 200001;
      double span = 8.0;
      for (int s = 0; s < n; ++s) {
        double t = double(p.t) - span / 2 + span * s / (n - 1);
        double rho = density(inv, f.position[i], o.x + t * d.x, o.y + t * d.y, o.z + t * d.z);
        if (rho > best_rho) {
          best_rho = rho;
          best_t = t;
        }
      }
      EXPECT_NEAR(p.response, best_rho, 2e-4 + 1e-4 * best_rho) << "gaussian " << i;
      // The peak position is only well defined where the response is curved enough.
      if (best_rho > 1e-3) {
        EXPECT_NEAR(p.t, best_t, 2e-3 + 1e-4 * std::fabs(best_t)) << "gaussian " << i;
      }
      checked++;
    }
  }
  EXPECT_EQ(checked, 200);
}

TEST(GaussianResponse, CullRuleMatchesAcceptRadius) {
  CullSettings cull;
  // Opaque Gaussian: the response limit binds, D^2 = 2 ln(1/0.0113).
  EXPECT_NEAR(accept_radius_sq(1.0f, cull), -2.0f * std::log(0.0113f), 1e-5f);
  // Faint Gaussian: the alpha limit binds.
  EXPECT_NEAR(accept_radius_sq(0.02f, cull), 2.0f * std::log(0.02f * 255.0f), 1e-5f);
  // Below the alpha limit it can never be hit.
  EXPECT_LT(accept_radius_sq(0.003f, cull), 0.0f);
  // Just inside / outside the radius.
  for (float sigma : {1.0f, 0.5f, 0.05f}) {
    float r2 = accept_radius_sq(sigma, cull);
    PeakResponse inside{0.0f, r2 * 0.999f, std::exp(-0.5f * r2 * 0.999f)};
    PeakResponse outside{0.0f, r2 * 1.001f, std::exp(-0.5f * r2 * 1.001f)};
    EXPECT_GT(hit_alpha(inside, sigma, cull), 0.0f) << sigma;
    EXPECT_EQ(hit_alpha(outside, sigma, cull), 0.0f) << sigma;
  }
  // Alpha is clamped to 0.99.
  PeakResponse centre{0.0f, 0.0f, 1.0f};
  EXPECT_FLOAT_EQ(hit_alpha(centre, 1.0f, cull), 0.99f);
}
