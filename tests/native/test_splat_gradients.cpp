// The adjoint of the ray-traced compositing (render/splat_composite.h) against
// central finite differences of the forward, for every Gaussian parameter the
// geometry stage optimises: position, log scale, rotation (quaternion), opacity,
// SH coefficients (degree 1) and the shading normal. Small k-buffers (k = 3) make
// rays take several traversal rounds, so hits move between rounds and
// buffers while the replay must still see them in order.
//
// The forward is piecewise smooth: the hit order (t_peak) and the cull boundary
// are discontinuities with no gradient. A difference quotient whose two sides
// visit other hits than the base is skipped (counted; most must be compared).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include "ptir/render/splat_composite.h"
#include "test_scenes.h"

using namespace ptir;

namespace {

constexpr int kSize = 10;

Camera test_camera() {
  const float c2w[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 3.0f, 0, 0, 0, 1};
  return make_camera(c2w, 0.45f, kSize, kSize);
}

// Overlapping Gaussians around the origin with SH degree 1 and random normals.
GaussianField cluster(uint32_t seed, int n = 10) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> g(0.0f, 1.0f);
  GaussianField f;
  for (int i = 0; i < n; ++i) {
    Vec3 mu(0.5f * (2 * u(rng) - 1), 0.5f * (2 * u(rng) - 1), 0.6f * (2 * u(rng) - 1));
    Vec3 s(0.08f + 0.22f * u(rng), 0.08f + 0.22f * u(rng), 0.05f + 0.2f * u(rng));
    test::add_gaussian(f, mu, s, {g(rng), g(rng), g(rng), g(rng)}, 0.3f + 0.6f * u(rng));
    f.normal.back() = normalize(Vec3(g(rng), g(rng), g(rng)));
  }
  f.sh_degree = 1;
  f.sh.resize(size_t(n) * 12);
  for (float& c : f.sh) c = 0.6f * g(rng);
  return f;
}

struct Adjoints {
  Image colour, opacity, normal, distortion;
};

Adjoints random_adjoints(uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Adjoints a{Image(kSize, kSize, {"R", "G", "B"}), Image(kSize, kSize, {"A"}), Image(kSize, kSize, {"X", "Y", "Z"}),
             Image(kSize, kSize, {"Y"})};
  for (float& v : a.colour.pixels) v = u(rng);
  for (float& v : a.opacity.pixels) v = u(rng);
  for (float& v : a.normal.pixels) v = u(rng);
  for (float& v : a.distortion.pixels) v = u(rng);
  return a;
}

// Only the distortion's adjoint: its gradient is checked on its own, not
// hidden under the colour's.
Adjoints distortion_adjoints(uint32_t seed) {
  Adjoints a = random_adjoints(seed);
  for (Image* im : {&a.colour, &a.opacity, &a.normal})
    for (float& v : im->pixels) v = 0.0f;
  for (float& v : a.distortion.pixels) v = 4.0f * v;
  return a;
}

AccelSettings small_k(int k) {
  AccelSettings s;
  s.k = k;
  return s;
}

// <adjoints, outputs> of the field's render.
double objective(const GaussianField& f, const Adjoints& a, int k) {
  SceneAccel accel(f, {}, small_k(k));
  SplatImage im = render_splat(accel, test_camera(), Vec3(0.2f, 0.1f, 0.05f));
  double s = 0;
  for (size_t i = 0; i < im.colour.pixels.size(); ++i) s += double(a.colour.pixels[i]) * im.colour.pixels[i];
  for (size_t i = 0; i < im.opacity.pixels.size(); ++i) s += double(a.opacity.pixels[i]) * im.opacity.pixels[i];
  for (size_t i = 0; i < im.normal.pixels.size(); ++i) s += double(a.normal.pixels[i]) * im.normal.pixels[i];
  for (size_t i = 0; i < im.distortion.pixels.size(); ++i)
    s += double(a.distortion.pixels[i]) * im.distortion.pixels[i];
  return s;
}

SplatGradients gradients(const GaussianField& f, const Adjoints& a, int k) {
  SceneAccel accel(f, {}, small_k(k));
  const Camera cam = test_camera();
  const Vec3 bg(0.2f, 0.1f, 0.05f);
  SplatImage im = render_splat(accel, cam, bg);
  SplatGradients g;
  g.resize(f.size(), f.sh_stride());
  render_splat_backward(accel, cam, bg, im, &a.colour, &a.opacity, &a.normal, g, {}, true, &a.distortion);
  return g;
}

// The ids every pixel's walk visits, in order: the pieces of the forward.
std::vector<uint32_t> hit_lists(const GaussianField& f) {
  SceneAccel accel(f, {});
  const Camera cam = test_camera();
  std::vector<uint32_t> ids;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      accel.walk(cam.generate_ray(x + 0.5f, y + 0.5f), [&](const GaussianHit& h) { return ids.push_back(h.id), true; },
                 nullptr, true);
      ids.push_back(~0u);
    }
  return ids;
}

struct Check {
  int compared = 0, skipped = 0;
  double max_err = 0, max_grad = 0;
};

// Central difference of parameter `set(field, delta)` against `analytic`.
void check_param(const GaussianField& base, const Adjoints& a, int k, float h,
                 const std::function<void(GaussianField&, float)>& set, double analytic, double tol_abs, Check& c,
                 const std::string& what) {
  GaussianField fp = base, fm = base;
  set(fp, h);
  set(fm, -h);
  const auto hits = hit_lists(base);
  if (hit_lists(fp) != hits || hit_lists(fm) != hits) {
    c.skipped++;
    return;
  }
  const double fd = (objective(fp, a, k) - objective(fm, a, k)) / (2.0 * h);
  const double err = std::fabs(fd - analytic);
  c.compared++;
  c.max_err = std::max(c.max_err, err);
  c.max_grad = std::max(c.max_grad, std::fabs(analytic));
  EXPECT_LE(err, tol_abs + 0.02 * std::fabs(fd)) << what << ": analytic " << analytic << " fd " << fd;
}

void normalise(std::array<float, 4>& q) {
  float l = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (float& v : q) v /= l;
}


// Every parameter's gradient of <a, outputs> against central differences (k = 3).
void check_every_parameter(const GaussianField& f, const Adjoints& a, bool with_sh_and_normal) {
  const int k = 3;
  // Rays with more than 2k hits: three rounds or more, the first two buffers full.
  int longest = 0, run = 0;
  for (uint32_t id : hit_lists(f)) run = id == ~0u ? (longest = std::max(longest, run), 0) : run + 1;
  EXPECT_GT(longest, 2 * k);
  const SplatGradients g = gradients(f, a, k);
  Check pos, scl, rot, opa, sh, nrm;
  const float h = 1e-3f;
  for (size_t i = 0; i < f.size(); ++i) {
    const std::string id = "Gaussian " + std::to_string(i);
    for (int j = 0; j < 3; ++j) {
      check_param(f, a, k, h, [&](GaussianField& x, float d) { x.position[i][j] += d; }, g.position[i][j], 2e-3, pos,
                  id + " position " + std::to_string(j));
      check_param(f, a, k, h, [&](GaussianField& x, float d) { x.scale[i][j] *= std::exp(d); }, g.log_scale[i][j], 2e-3,
                  scl, id + " log scale " + std::to_string(j));
      check_param(f, a, k, h, [&](GaussianField& x, float d) { x.normal[i][j] += d; }, g.normal[i][j], 1e-3, nrm,
                  id + " normal " + std::to_string(j));
    }
    // Rotation: raw quaternion perturbed then normalised; the gradient projected
    // onto the unit sphere's tangent.
    const auto& q = f.rotation[i];
    const auto& gq = g.rotation[i];
    const float qg = q[0] * gq[0] + q[1] * gq[1] + q[2] * gq[2] + q[3] * gq[3];
    for (int j = 0; j < 4; ++j)
      check_param(f, a, k, h, [&](GaussianField& x, float d) { x.rotation[i][j] += d, normalise(x.rotation[i]); },
                  gq[j] - qg * q[j], 2e-3, rot, id + " rotation " + std::to_string(j));
    check_param(f, a, k, h, [&](GaussianField& x, float d) { x.opacity[i] += d; }, g.opacity[i], 2e-3, opa,
                id + " opacity");
    for (int j : {0, 1, 5, 10})
      check_param(f, a, k, h, [&](GaussianField& x, float d) { x.sh[i * 12 + j] += d; }, g.sh[i * 12 + j], 1e-3, sh,
                  id + " sh " + std::to_string(j));
  }
  for (const Check* c : {&pos, &scl, &rot, &opa, &sh, &nrm}) {
    if (!with_sh_and_normal && (c == &sh || c == &nrm)) continue;  // the distortion does not see them
    EXPECT_GE(c->compared, 3 * (c->compared + c->skipped) / 4);
    EXPECT_GT(c->max_grad, 0.05);  // the parameters matter
  }
  std::printf("compared/skipped: position %d/%d scale %d/%d rotation %d/%d opacity %d/%d sh %d/%d normal %d/%d\n",
              pos.compared, pos.skipped, scl.compared, scl.skipped, rot.compared, rot.skipped, opa.compared, opa.skipped,
              sh.compared, sh.skipped, nrm.compared, nrm.skipped);
  std::printf("max |error| (max |gradient|): position %.2e (%.2f) scale %.2e (%.2f) rotation %.2e (%.2f) opacity %.2e "
              "(%.2f) sh %.2e (%.2f) normal %.2e (%.2f)\n",
              pos.max_err, pos.max_grad, scl.max_err, scl.max_grad, rot.max_err, rot.max_grad, opa.max_err, opa.max_grad,
              sh.max_err, sh.max_grad, nrm.max_err, nrm.max_grad);
}

}  // namespace

TEST(SplatGradients, MatchFiniteDifferencesAcrossRounds) { check_every_parameter(cluster(7), random_adjoints(3), true); }

// The depth distortion alone: through the weights and through t_peak.
TEST(SplatGradients, DistortionMatchesFiniteDifferences) {
  check_every_parameter(cluster(7), distortion_adjoints(3), false);
}

// The k-buffer size changes how the hits are collected, never which or in what
// order: the gradients are the same (to float rounding of the sums).
TEST(SplatGradients, IndependentOfKBufferSize) {
  const GaussianField f = cluster(11, 14);
  const Adjoints a = random_adjoints(5);
  const SplatGradients g4 = gradients(f, a, 4), g32 = gradients(f, a, 32);
  for (size_t i = 0; i < f.size(); ++i) {
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR(g4.position[i][j], g32.position[i][j], 1e-5f);
      EXPECT_NEAR(g4.log_scale[i][j], g32.log_scale[i][j], 1e-5f);
    }
    EXPECT_NEAR(g4.opacity[i], g32.opacity[i], 1e-5f);
  }
}

// A ray that turns opaque stops (T < 0.001): the Gaussians behind the cut are
// never visited and get no gradient, those in front match finite differences,
// including where alpha is clamped at 0.99 (no gradient there either).
TEST(SplatGradients, OpaqueCutAndClampedAlpha) {
  GaussianField f;
  test::add_gaussian(f, Vec3(0.05f, 0.0f, 0.4f), Vec3(0.5f, 0.4f, 0.05f), {1, 0.1f, 0.2f, 0}, 0.9995f);
  test::add_gaussian(f, Vec3(-0.05f, 0.05f, 0.1f), Vec3(0.45f, 0.5f, 0.05f), {1, -0.1f, 0, 0.3f}, 0.9995f);
  test::add_gaussian(f, Vec3(0.0f, 0.0f, -0.3f), Vec3(0.3f, 0.3f, 0.1f), {1, 0, 0, 0}, 0.8f);
  f.sh_degree = 0;
  const Adjoints a = random_adjoints(9);
  const SplatGradients g = gradients(f, a, 32);
  // The back Gaussian: reached only where the front two leave T >= 0.001, so its
  // gradient is that of the rim pixels; the finite differences agree everywhere.
  Check c;
  for (size_t i = 0; i < f.size(); ++i)
    for (int j = 0; j < 3; ++j) {
      check_param(f, a, 32, 1e-3f, [&](GaussianField& x, float d) { x.position[i][j] += d; }, g.position[i][j], 2e-3, c,
                  "position");
      check_param(f, a, 32, 1e-3f, [&](GaussianField& x, float d) { x.scale[i][j] *= std::exp(d); }, g.log_scale[i][j],
                  2e-3, c, "log scale");
    }
  EXPECT_GE(c.compared, 12);
  // The centre pixel's walk stops before the back Gaussian.
  SceneAccel accel(f, {});
  std::vector<uint32_t> ids;
  accel.walk(test_camera().generate_ray(kSize / 2 + 0.5f, kSize / 2 + 0.5f),
             [&](const GaussianHit& h) { return ids.push_back(h.id), true; }, nullptr, true);
  EXPECT_EQ(ids, (std::vector<uint32_t>{0, 1}));
}
