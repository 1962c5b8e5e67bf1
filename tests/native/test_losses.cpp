// Image objectives of optim/losses.h: values computed by hand, SSIM against
// scikit-image reference numbers, the binomial filter's adjoint, masks, and every
// gradient against central finite differences.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>

#include "ptir/core/error.h"
#include "ptir/optim/losses.h"

using namespace ptir;

namespace {

Image make_image(int w, int h, int c) {
  static const char* names[] = {"R", "G", "B", "A"};
  std::vector<std::string> n;
  for (int i = 0; i < c; ++i) n.push_back(c == 1 ? "Y" : names[i]);
  return Image(w, h, n);
}

Image random_image(int w, int h, int c, uint32_t seed, float lo = 0.0f, float hi = 1.0f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  Image img = make_image(w, h, c);
  for (float& v : img.pixels) v = u(rng);
  return img;
}

// The generators of the scikit-image reference script (values in the comments of
// SsimMatchesScikitImage): the same integer hash and smooth patterns as numpy.
Image hash_image(int w, int h, int seed) {
  Image img = make_image(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        uint64_t v = (uint64_t(x * 37 + y * 91 + c * 53 + seed * 1013) * 2654435761ULL) & 0xffffffffULL;
        img.at(x, y, c) = float(double(v >> 22) / 1024.0);
      }
  return img;
}

void smooth_pair(int w, int h, Image& a, Image& b) {
  a = make_image(w, h, 3);
  b = make_image(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        double va = 0.5 + 0.3 * std::sin(0.4 * x + 0.7 * c) * std::cos(0.3 * y - 0.2 * c) +
                    0.1 * double((x * 7 + y * 13 + c * 5) % 11) / 11.0;
        double vb = va + 0.15 * std::sin(0.9 * x + 1.3 * y + c);
        if (!(x > w / 2)) vb = 0.8 * vb + 0.1;
        a.at(x, y, c) = float(va);
        b.at(x, y, c) = float(vb);
      }
}

double dot(const Image& a, const Image& b) {
  double s = 0.0;
  for (size_t i = 0; i < a.pixels.size(); ++i) s += double(a.pixels[i]) * double(b.pixels[i]);
  return s;
}

// Central differences of f at a few random entries of `img`, compared with `grad`.
// The objectives are evaluated in double from float inputs, so the step actually
// taken is the difference of the two stored floats.
template <class F>
void check_gradient(Image img, const Image& grad, F f, int probes, uint32_t seed, double h, double rel_tol,
                    double abs_tol, const char* what) {
  ASSERT_EQ(grad.width, img.width);
  ASSERT_EQ(grad.height, img.height);
  std::mt19937 rng(seed);
  double worst = 0.0;
  for (int k = 0; k < probes; ++k) {
    int x = int(rng() % uint32_t(img.width)), y = int(rng() % uint32_t(img.height));
    int c = int(rng() % uint32_t(grad.channels));
    float v0 = img.at(x, y, c);
    float vp = float(v0 + h), vm = float(v0 - h);
    img.at(x, y, c) = vp;
    double fp = f(img);
    img.at(x, y, c) = vm;
    double fm = f(img);
    img.at(x, y, c) = v0;
    double fd = (fp - fm) / (double(vp) - double(vm));
    double an = grad.at(x, y, c);
    double err = std::abs(fd - an);
    worst = std::max(worst, err / (std::abs(fd) + abs_tol / rel_tol));
    EXPECT_NEAR(an, fd, rel_tol * std::abs(fd) + abs_tol) << what << " at (" << x << "," << y << "," << c << ")";
  }
  std::printf("  %-34s worst relative error %.2e over %d probes\n", what, worst, probes);
}

// A target whose values stay >= 0.05 away from the (blurred) prediction, so the
// L1 term has no kink within a finite-difference step.
Image target_away_from(const Image& blurred, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.05f, 0.25f);
  Image t = make_image(blurred.width, blurred.height, 3);
  for (int y = 0; y < t.height; ++y)
    for (int x = 0; x < t.width; ++x)
      for (int c = 0; c < 3; ++c) t.at(x, y, c) = blurred.at(x, y, c) + ((rng() & 1) ? u(rng) : -u(rng));
  return t;
}

}  // namespace

TEST(Losses, BinomialFilterKnownValues) {
  Image img = make_image(5, 5, 1);
  img.at(2, 2, 0) = 16.0f;
  Image f = binomial_filter(img);
  const float k[3][3] = {{1, 2, 1}, {2, 4, 2}, {1, 2, 1}};
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) {
      float expect = (std::abs(x - 2) <= 1 && std::abs(y - 2) <= 1) ? k[y - 1][x - 1] : 0.0f;
      EXPECT_FLOAT_EQ(f.at(x, y, 0), expect) << x << "," << y;
    }
  // Clamped edge: a corner impulse keeps (3/4)^2 in place, 3/16 to each neighbour.
  Image corner = make_image(3, 3, 1);
  corner.at(0, 0, 0) = 1.0f;
  Image fc = binomial_filter(corner);
  EXPECT_FLOAT_EQ(fc.at(0, 0, 0), 0.5625f);
  EXPECT_FLOAT_EQ(fc.at(1, 0, 0), 0.1875f);
  EXPECT_FLOAT_EQ(fc.at(1, 1, 0), 0.0625f);
  EXPECT_FLOAT_EQ(fc.at(2, 2, 0), 0.0f);
  // A constant image is unchanged (normalised weights).
  Image ones = make_image(4, 3, 2);
  for (float& v : ones.pixels) v = 0.7f;
  for (float v : binomial_filter(ones).pixels) EXPECT_FLOAT_EQ(v, 0.7f);
}

TEST(Losses, BinomialAdjointIsTranspose) {
  for (auto [w, h] : {std::pair{1, 1}, std::pair{2, 7}, std::pair{17, 13}}) {
    Image x = random_image(w, h, 3, 1, -1, 1), y = random_image(w, h, 3, 2, -1, 1);
    double lhs = dot(binomial_filter(x), y), rhs = dot(x, binomial_filter_adjoint(y));
    std::printf("  %dx%d: <Ax,y> = %.9f, <x,A^T y> = %.9f\n", w, h, lhs, rhs);
    EXPECT_NEAR(lhs, rhs, 1e-5 * (1.0 + std::abs(lhs)));
  }
}

TEST(Losses, SsimOfIdenticalImagesIsOne) {
  Image a = random_image(20, 15, 3, 3);
  EXPECT_NEAR(ssim(a, a), 1.0, 1e-12);
  Image mask = random_image(20, 15, 1, 4);
  EXPECT_NEAR(ssim(a, a, &mask), 1.0, 1e-12);
  Image tiny = random_image(4, 3, 3, 5);  // smaller than the window: no crop, still defined
  EXPECT_NEAR(ssim(tiny, tiny), 1.0, 1e-12);
  ImageLossSettings s;
  s.binomial_filter = false;
  Image d;
  EXPECT_NEAR(image_loss(a, a, nullptr, s, &d), 0.0, 1e-12);
}

TEST(Losses, SsimMatchesScikitImage) {
  // skimage.metrics.structural_similarity(a, b, channel_axis=2, gaussian_weights=True,
  // sigma=1.5, use_sample_covariance=False, data_range=1.0) on the float32 images
  // of this file's generators, promoted to float64 (scikit-image 0.19.3).
  struct Case {
    int w, h;
    double smooth, hash, mix;
  };
  const Case cases[] = {{23, 17, 0.650351021504, 0.648802779441, 0.287513085888},
                        {11, 11, 0.607103000011, 0.515762562323, 0.174350429219},
                        {40, 31, 0.661578150540, 0.630355338758, 0.301225486933}};
  double worst = 0.0;
  for (const Case& k : cases) {
    Image a, b;
    smooth_pair(k.w, k.h, a, b);
    Image r1 = hash_image(k.w, k.h, 1), r2 = hash_image(k.w, k.h, 2);
    Image m = a;
    for (size_t i = 0; i < m.pixels.size(); ++i) m.pixels[i] = 0.5f * a.pixels[i] + 0.5f * r1.pixels[i];
    double s1 = ssim(a, b), s2 = ssim(r1, r2), s3 = ssim(a, m);
    EXPECT_NEAR(s1, k.smooth, 1e-9) << k.w << "x" << k.h;
    EXPECT_NEAR(s2, k.hash, 1e-9) << k.w << "x" << k.h;
    EXPECT_NEAR(s3, k.mix, 1e-9) << k.w << "x" << k.h;
    worst = std::max({worst, std::abs(s1 - k.smooth), std::abs(s2 - k.hash), std::abs(s3 - k.mix)});
  }
  std::printf("  worst |ssim - skimage| = %.2e\n", worst);
}

// A 2x2, 3-channel prediction/target pair with known differences, and loss
// settings without SSIM or blur: |diff| = .1 .2 0 | 0 .5 0 | .2 0 0 | 1 0 .25.
static void known_pair(Image& p, Image& t, ImageLossSettings& s) {
  p = make_image(2, 2, 3), t = make_image(2, 2, 3);
  const float pv[12] = {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f, 0.8f, 0.9f, 1.0f, 0.0f, 0.5f};
  const float tv[12] = {0.0f, 0.4f, 0.3f, 0.4f, 0.0f, 0.6f, 0.5f, 0.8f, 0.9f, 0.0f, 0.0f, 0.25f};
  for (int i = 0; i < 12; ++i) p.pixels[size_t(i)] = pv[i], t.pixels[size_t(i)] = tv[i];
  s.lambda_ssim = 0.0f;
  s.binomial_filter = false;
}

TEST(Losses, L1KnownValues) {
  // No SSIM, no blur: mean |pred - target| over 12 values.
  Image p, t;
  ImageLossSettings s;
  known_pair(p, t, s);  // |diff| sums to 2.25 over 12 values
  Image d;
  EXPECT_NEAR(image_loss(p, t, nullptr, s, &d), 2.25 / 12.0, 1e-7);
  ASSERT_EQ(d.channels, 3);
  EXPECT_FLOAT_EQ(d.pixels[0], 1.0f / 12.0f);    // pred > target
  EXPECT_FLOAT_EQ(d.pixels[1], -1.0f / 12.0f);   // pred < target
  EXPECT_FLOAT_EQ(d.pixels[2], 0.0f);            // equal: zero subgradient
  // Mask (4 channels: alpha is channel 3) weights pixels 1, 0.5, 0, 0 ->
  // (0.3 * 1 + 0.5 * 0.5) / (3 * 1.5).
  Image mask = make_image(2, 2, 4);
  const float alpha[4] = {1.0f, 0.5f, 0.0f, 0.0f};
  for (int i = 0; i < 4; ++i) mask.pixels[size_t(i) * 4 + 3] = alpha[i];
  EXPECT_NEAR(image_loss(p, t, &mask, s, &d), (0.3 + 0.25) / 4.5, 1e-7);
  EXPECT_FLOAT_EQ(d.pixels[4], 0.5f / 4.5f);
  EXPECT_FLOAT_EQ(d.pixels[9], 0.0f);
  // Same with a 1-channel mask; a 2-channel mask is refused; an empty mask gives 0.
  Image m1 = make_image(2, 2, 1);
  for (int i = 0; i < 4; ++i) m1.pixels[size_t(i)] = alpha[i];
  EXPECT_NEAR(image_loss(p, t, &m1, s, nullptr), (0.3 + 0.25) / 4.5, 1e-7);
  Image m2 = make_image(2, 2, 2);
  EXPECT_THROW(image_loss(p, t, &m2, s, nullptr), Error);
  Image m0 = make_image(2, 2, 1);
  EXPECT_EQ(image_loss(p, t, &m0, s, &d), 0.0);
  // With the full objective, lambda weighs the two terms.
  s.lambda_ssim = 0.2f;
  double expect = 0.8 * 2.25 / 12.0 + 0.2 * (1.0 - ssim(p, t));
  EXPECT_NEAR(image_loss(p, t, nullptr, s, nullptr), expect, 1e-7);
}

TEST(Losses, HuberKnownValues) {
  // The L1KnownValues pair with a knee at 0.3: |diff| .1 .2 .2 .25 are inside
  // (x^2 / 0.6), .5 and 1 outside (|x| - 0.15).
  Image p, t;
  ImageLossSettings s;
  known_pair(p, t, s);
  s.huber_delta = 0.3f;
  const double inside = (0.01 + 0.04 + 0.04 + 0.0625) / 0.6, outside = (0.5 - 0.15) + (1.0 - 0.15);
  Image d;
  EXPECT_NEAR(image_loss(p, t, nullptr, s, &d), (inside + outside) / 12.0, 1e-6);
  EXPECT_NEAR(d.pixels[0], 0.1 / 0.3 / 12.0, 1e-6);   // inside: linear in the difference
  EXPECT_NEAR(d.pixels[1], -0.2 / 0.3 / 12.0, 1e-6);
  EXPECT_FLOAT_EQ(d.pixels[4], 1.0f / 12.0f);          // outside: L1's slope
  EXPECT_FLOAT_EQ(d.pixels[2], 0.0f);
}

TEST(Losses, MaskedVersusUnmasked) {
  Image p = random_image(30, 26, 4, 10), t = random_image(30, 26, 3, 11);
  ImageLossSettings s;
  Image ones = make_image(30, 26, 1);
  for (float& v : ones.pixels) v = 1.0f;
  Image d0, d1;
  double l0 = image_loss(p, t, nullptr, s, &d0), l1 = image_loss(p, t, &ones, s, &d1);
  EXPECT_DOUBLE_EQ(l0, l1);
  for (size_t i = 0; i < d0.pixels.size(); ++i) ASSERT_FLOAT_EQ(d0.pixels[i], d1.pixels[i]);
  EXPECT_DOUBLE_EQ(ssim(p, t), ssim(p, t, &ones));
  // Mask only the left third: pixels farther right than blur radius (1) + SSIM
  // window radius (5) cannot change the loss and get no gradient.
  Image left = make_image(30, 26, 1);
  for (int y = 0; y < 26; ++y)
    for (int x = 0; x < 10; ++x) left.at(x, y, 0) = 1.0f;
  double base = image_loss(p, t, &left, s, &d1);
  EXPECT_NE(base, l0);
  Image q = p;
  for (int y = 0; y < 26; ++y)
    for (int x = 17; x < 30; ++x)
      for (int c = 0; c < 3; ++c) q.at(x, y, c) = 1.0f - q.at(x, y, c);
  EXPECT_DOUBLE_EQ(image_loss(q, t, &left, s, nullptr), base);
  for (int y = 0; y < 26; ++y)
    for (int x = 17; x < 30; ++x)
      for (int c = 0; c < 3; ++c) ASSERT_EQ(d1.at(x, y, c), 0.0f);
  // The pred's alpha channel is not compared.
  Image p2 = p;
  for (int y = 0; y < 26; ++y)
    for (int x = 0; x < 30; ++x) p2.at(x, y, 3) = 0.123f;
  EXPECT_DOUBLE_EQ(image_loss(p2, t, nullptr, s, nullptr), l0);
}

TEST(Losses, ImageLossGradientMatchesFiniteDifferences) {
  const int w = 26, h = 21;
  Image p = random_image(w, h, 3, 20, 0.1f, 0.9f);
  Image t = target_away_from(binomial_filter(p), 21);
  Image t_noblur = target_away_from(p, 22);
  Image mask = random_image(w, h, 1, 23);
  for (int y = 0; y < h; ++y) mask.at(0, y, 0) = mask.at(1, y, 0) = 0.0f;

  struct Variant {
    const char* name;
    float lambda;
    bool blur;
    const Image* mask;
    float huber = 0.0f;
    bool blur_target = false;
  };
  const Variant variants[] = {{"L1 + D-SSIM, binomial", 0.2f, true, nullptr},
                              {"L1 + D-SSIM, binomial, masked", 0.2f, true, &mask},
                              {"D-SSIM only, no blur", 1.0f, false, nullptr},
                              {"D-SSIM only, binomial, masked", 1.0f, true, &mask},
                              {"L1 only, no blur, masked", 0.0f, false, &mask},
                              {"Huber 0.15 + D-SSIM, binomial, masked", 0.2f, true, &mask, 0.15f},
                              {"L1 + D-SSIM, both blurred, masked", 0.2f, true, &mask, 0.0f, true}};
  uint32_t seed = 100;
  for (const Variant& v : variants) {
    ImageLossSettings s;
    s.lambda_ssim = v.lambda;
    s.binomial_filter = v.blur;
    s.huber_delta = v.huber;
    s.blur_target = v.blur_target;
    const Image& target = v.blur ? t : t_noblur;
    Image d;
    image_loss(p, target, v.mask, s, &d);
    ASSERT_EQ(d.channels, 3);
    check_gradient(p, d, [&](const Image& img) { return image_loss(img, target, v.mask, s, nullptr); }, 60, seed++,
                   1e-3, 2e-3, 1e-8, v.name);
  }
}

// Blurring the prediction alone moves the optimum: for a textured target, the
// target itself is not a minimiser (blur(target) != target); blurring both images
// makes it one again (zero loss, zero gradient), and the loss is then the loss of
// the two blurred images without a blur.
TEST(Losses, BlurredTargetKeepsTheTargetOptimal) {
  Image t = random_image(24, 20, 3, 40, 0.1f, 0.9f);
  ImageLossSettings s;  // L1 + D-SSIM, prediction blurred
  Image d;
  EXPECT_GT(image_loss(t, t, nullptr, s, &d), 0.01);
  double g = 0.0;
  for (float v : d.pixels) g += std::abs(v);
  EXPECT_GT(g, 0.1);
  s.blur_target = true;
  EXPECT_NEAR(image_loss(t, t, nullptr, s, &d), 0.0, 1e-9);
  for (float v : d.pixels) ASSERT_NEAR(v, 0.0f, 1e-7f);
  Image p = random_image(24, 20, 3, 41, 0.1f, 0.9f);
  ImageLossSettings plain;
  plain.binomial_filter = false;
  EXPECT_NEAR(image_loss(p, t, nullptr, s, nullptr), image_loss(binomial_filter(p), binomial_filter(t), nullptr, plain, nullptr),
              1e-6);  // binomial_filter rounds the blurred images to float
}

TEST(Losses, EdgeAwareTvKnownValues) {
  // 2x2 map, 1 channel: values 0 1 / 0 3. Guide: flat except the bottom-right
  // pixel, 0.3 brighter in every channel (mean |difference| 0.3 on its two pairs).
  Image map = make_image(2, 2, 1), guide = make_image(2, 2, 3);
  map.at(1, 0, 0) = 1.0f;
  map.at(1, 1, 0) = 3.0f;
  for (int c = 0; c < 3; ++c) guide.at(1, 1, c) = 0.3f;
  // Pairs: (0,0)-(1,0): 1 * 1; (0,0)-(0,1): 0; (1,0)-(1,1): 4 e^-0.3; (0,1)-(1,1): 9 e^-0.3.
  double e = std::exp(-double(0.3f));
  double expect = (1.0 + 13.0 * e) / 4.0;
  Image d;
  EXPECT_NEAR(edge_aware_tv(map, guide, nullptr, &d), expect, 1e-7);
  // d/d map(1,1) = 2 e (3 - 1) + 2 e (3 - 0), over 4 pairs.
  EXPECT_NEAR(d.at(1, 1, 0), (4.0 * e + 6.0 * e) / 4.0, 1e-6);
  // Mask: pair weight w_p w_q; masking out (1,1) leaves the two top/left pairs.
  Image mask = make_image(2, 2, 1);
  for (float& v : mask.pixels) v = 1.0f;
  mask.at(1, 1, 0) = 0.0f;
  EXPECT_NEAR(edge_aware_tv(map, guide, &mask, &d), 1.0 / 2.0, 1e-7);
  EXPECT_EQ(d.at(1, 1, 0), 0.0f);
  // A constant map has no variation.
  Image flat = make_image(5, 4, 3);
  for (float& v : flat.pixels) v = 0.4f;
  EXPECT_EQ(edge_aware_tv(flat, random_image(5, 4, 3, 7), nullptr, nullptr), 0.0);
}

TEST(Losses, EdgeAwareTvGradientMatchesFiniteDifferences) {
  Image map = random_image(13, 9, 3, 30), guide = random_image(13, 9, 4, 31), mask = random_image(13, 9, 1, 32);
  for (const Image* m : {(const Image*)nullptr, (const Image*)&mask}) {
    Image d;
    edge_aware_tv(map, guide, m, &d);
    ASSERT_EQ(d.channels, 3);
    check_gradient(map, d, [&](const Image& img) { return edge_aware_tv(img, guide, m, nullptr); }, 40, 33, 1e-3, 1e-4,
                   1e-8, m ? "edge-aware TV, masked" : "edge-aware TV");
  }
  Image rough = random_image(13, 9, 1, 34), d;
  edge_aware_tv(rough, guide, nullptr, &d);
  check_gradient(rough, d, [&](const Image& img) { return edge_aware_tv(img, guide, nullptr, nullptr); }, 20, 35, 1e-3,
                 1e-4, 1e-8, "edge-aware TV, 1 channel");
}

TEST(Losses, ChromaGuideSmoothsShadowEdgesNotColourEdges) {
  // One row of three pixels, linear RGB: a cream surface in light, the same cream in
  // shadow (x 0.2), and a lavender surface as bright as the lit cream.
  const float cream[3] = {0.9f, 0.85f, 0.7f}, lavender[3] = {0.75f, 0.7f, 0.95f};
  Image rgb = make_image(3, 1, 3);
  for (int c = 0; c < 3; ++c) {
    rgb.at(0, 0, c) = cream[c];
    rgb.at(1, 0, c) = 0.2f * cream[c];
    rgb.at(2, 0, c) = lavender[c];
  }
  const float k = 30.0f;
  Image g = chroma_guide(rgb, k);
  // Closed form: k c / (r + g + b + eps).
  const double lit = 0.9 + 0.85 + 0.7, dark = 0.2 * lit, lav = 0.75 + 0.7 + 0.95;
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(g.at(0, 0, c), k * cream[c] / (lit + kChromaGuideEps), 1e-5);
    EXPECT_NEAR(g.at(1, 0, c), k * 0.2 * cream[c] / (dark + kChromaGuideEps), 1e-5);
    EXPECT_NEAR(g.at(2, 0, c), k * lavender[c] / (lav + kChromaGuideEps), 1e-5);
  }
  // Each pair's TV weight, read from edge_aware_tv on a map with a unit step at that pair
  // only: value = weight * 1 / (number of pairs).
  auto weight = [](const Image& guide, int x0) {
    Image one = make_image(2, 1, 1), pair_guide = make_image(2, 1, 3);
    one.at(1, 0, 0) = 1.0f;
    for (int x = 0; x < 2; ++x)
      for (int c = 0; c < 3; ++c) pair_guide.at(x, 0, c) = guide.at(x0 + x, 0, c);
    return edge_aware_tv(one, pair_guide, nullptr, nullptr);
  };
  double shadow = 0.0, colour = 0.0;
  for (int c = 0; c < 3; ++c) {
    shadow += std::abs(double(g.at(0, 0, c)) - double(g.at(1, 0, c)));
    colour += std::abs(double(g.at(0, 0, c)) - double(g.at(2, 0, c)));
  }
  EXPECT_NEAR(weight(g, 0), std::exp(-shadow / 3.0), 1e-6);
  EXPECT_GT(weight(g, 0), 0.9);  // the shadow edge: smoothed (only eps tells it from the lit side)
  Image lit_lav = make_image(2, 1, 3);
  for (int c = 0; c < 3; ++c) {
    lit_lav.at(0, 0, c) = g.at(0, 0, c);
    lit_lav.at(1, 0, c) = g.at(2, 0, c);
  }
  EXPECT_NEAR(weight(lit_lav, 0), std::exp(-colour / 3.0), 1e-6);
  EXPECT_LT(weight(lit_lav, 0), 0.25);  // the colour edge: hardly
  // The intensity guide (the loss-space target) does the opposite: the shadow edge is
  // its strongest, the equally bright colour edge its weakest.
  Image srgb = make_image(3, 1, 3);
  for (size_t i = 0; i < srgb.pixels.size(); ++i) srgb.pixels[i] = srgb_encode_unclamped(rgb.pixels[i]);
  EXPECT_LT(weight(srgb, 0), weight(g, 0) - 0.2);
  EXPECT_THROW(chroma_guide(make_image(2, 2, 1), k), Error);
}

TEST(Losses, PriorL2) {
  Image map = make_image(2, 1, 1), prior = make_image(2, 1, 1);
  map.at(0, 0, 0) = 0.5f;
  map.at(1, 0, 0) = 0.25f;
  prior.at(1, 0, 0) = 0.75f;
  Image d;
  EXPECT_NEAR(prior_l2(map, prior, nullptr, &d), (0.25 + 0.25) / 2.0, 1e-9);
  EXPECT_FLOAT_EQ(d.at(0, 0, 0), 0.5f);
  EXPECT_FLOAT_EQ(d.at(1, 0, 0), -0.5f);
  Image mask = make_image(2, 1, 1);
  mask.at(1, 0, 0) = 1.0f;
  EXPECT_NEAR(prior_l2(map, prior, &mask, &d), 0.25, 1e-9);
  EXPECT_EQ(d.at(0, 0, 0), 0.0f);

  Image a = random_image(9, 7, 3, 40), b = random_image(9, 7, 3, 41), m = random_image(9, 7, 1, 42);
  prior_l2(a, b, &m, &d);
  check_gradient(a, d, [&](const Image& img) { return prior_l2(img, b, &m, nullptr); }, 30, 43, 1e-3, 1e-4, 1e-9,
                 "prior L2, masked");
}

TEST(Losses, FullSizeImageIsFast) {
  Image p = random_image(800, 800, 4, 50), t = random_image(800, 800, 4, 51);
  ImageLossSettings s;
  Image d;
  auto t0 = std::chrono::steady_clock::now();
  double l = image_loss(p, t, &t, s, &d);
  double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("  800x800 image_loss with gradient: %.3f s (loss %.4f)\n", sec, l);
  EXPECT_TRUE(std::isfinite(l));
  EXPECT_LT(sec, 10.0);
}
