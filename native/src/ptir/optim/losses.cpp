// Image objectives of the inversion (docs/method.md §6) and their exact adjoints.
//
// Everything is computed in double on single-channel planes. Every linear filter
// (the binomial blur, the SSIM Gaussian window) is a separable product of 1D
// filters, each stored as a small sparse matrix (per output sample: its input
// samples and weights, boundary handling folded in). The adjoint of a filter is
// the transposed matrix, built once, so forward and adjoint passes are the same
// gather loop: exact transposes, deterministic, parallel over rows.
//
// Definitions (see losses.h for the user-facing summary):
//   w_p      mask weight of pixel p: the mask's only channel, or its channel 3 (alpha)
//            when it has >= 4 channels, clamped to [0, 1]; 1 everywhere without mask.
//   L1       sum_p w_p sum_c |x_pc - y_pc| / (nc * sum_p w_p), over all pixels.
//   SSIM_c   the scikit-image SSIM map of channel c (Gaussian window sigma 1.5 with
//            scipy's truncate 3.5 -> 11 taps, mode 'reflect', population
//            covariances, C1 = 0.01^2, C2 = 0.03^2), computed on the whole image.
//   mean SSIM  (1/nc) sum_c sum_p v_p SSIM_c(p) with v_p = w_p k_p / sum_q w_q k_q,
//            k_p = 1 inside the image cropped by 5 pixels on every side (skimage's
//            crop of (win_size - 1) / 2), 0 in that border; an axis shorter than 11
//            pixels is not cropped (skimage refuses such images).
//   Empty mask (zero weight sum): L1 = 0 and mean SSIM = 1, with zero gradients.
#include "ptir/optim/losses.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "ptir/core/error.h"

namespace ptir {

float srgb_encode_unclamped(float c) {
  c = std::max(c, 0.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

float srgb_encode_derivative(float c) {
  c = std::max(c, 0.0f);
  return c <= 0.0031308f ? 12.92f : (1.055f / 2.4f) * std::pow(c, 1.0f / 2.4f - 1.0f);
}

namespace {

constexpr double kC1 = 0.01 * 0.01;
constexpr double kC2 = 0.03 * 0.03;
constexpr double kSsimSigma = 1.5;
constexpr int kSsimRadius = 5;  // int(3.5 * 1.5 + 0.5), scipy's radius for truncate = 3.5

using Plane = std::vector<double>;  // height * width, row-major

// A 1D linear filter on n samples as a sparse matrix: output i = sum over
// k in [start[i], start[i+1]) of weight[k] * input[index[k]].
// Rows [lo, hi) are "regular": exactly the samples i - r .. i + r with weights
// taps[0 .. 2r], so passes over them run as shifted vectorisable sweeps.
struct Filter1D {
  int n = 0;
  std::vector<int> start, index;
  std::vector<double> weight;
  int r = 0, lo = 0, hi = 0;
  std::vector<double> taps;

  // Finds the first run of regular rows for the given taps.
  void find_regular(const std::vector<double>& t) {
    taps = t;
    r = int(t.size()) / 2;
    auto regular = [&](int i) {
      if (start[size_t(i) + 1] - start[size_t(i)] != int(t.size())) return false;
      for (int m = 0; m < int(t.size()); ++m) {
        size_t k = size_t(start[size_t(i)] + m);
        if (index[k] != i - r + m || weight[k] != t[size_t(m)]) return false;
      }
      return true;
    };
    lo = hi = 0;
    int i = 0;
    while (i < n && !regular(i)) ++i;
    lo = hi = i;
    while (hi < n && regular(hi)) ++hi;
  }

  Filter1D transposed() const {
    Filter1D t;
    t.n = n;
    t.start.assign(size_t(n) + 1, 0);
    for (int j : index) ++t.start[size_t(j) + 1];
    for (int i = 0; i < n; ++i) t.start[size_t(i) + 1] += t.start[size_t(i)];
    t.index.resize(index.size());
    t.weight.resize(weight.size());
    std::vector<int> fill(t.start.begin(), t.start.end() - 1);
    for (int i = 0; i < n; ++i)
      for (int k = start[size_t(i)]; k < start[size_t(i) + 1]; ++k) {
        int j = index[size_t(k)];
        int slot = fill[size_t(j)]++;
        t.index[size_t(slot)] = i;
        t.weight[size_t(slot)] = weight[size_t(k)];
      }
    t.find_regular(std::vector<double>(taps.rbegin(), taps.rend()));
    return t;
  }
};

// scipy.ndimage 'reflect' (half-sample symmetric: d c b a | a b c d | d c b a),
// periodic with period 2n for offsets beyond one reflection.
int reflect_index(int i, int n) {
  if (n == 1) return 0;
  int period = 2 * n;
  int j = i % period;
  if (j < 0) j += period;
  return j < n ? j : period - 1 - j;
}

int clamp_index(int i, int n) { return std::min(std::max(i, 0), n - 1); }

template <class Boundary>
Filter1D make_filter(int n, const std::vector<double>& taps, Boundary boundary) {
  int r = int(taps.size()) / 2;
  Filter1D f;
  f.n = n;
  f.start.reserve(size_t(n) + 1);
  f.start.push_back(0);
  for (int i = 0; i < n; ++i) {
    // Merge repeated input samples (boundary folds) into one entry each.
    size_t row_begin = f.index.size();
    for (int k = -r; k <= r; ++k) {
      int j = boundary(i + k, n);
      double w = taps[size_t(k + r)];
      bool merged = false;
      for (size_t e = row_begin; e < f.index.size(); ++e)
        if (f.index[e] == j) {
          f.weight[e] += w;
          merged = true;
          break;
        }
      if (!merged) {
        f.index.push_back(j);
        f.weight.push_back(w);
      }
    }
    f.start.push_back(int(f.index.size()));
  }
  f.find_regular(taps);
  return f;
}

// scipy.ndimage._gaussian_kernel1d (order 0): exp(-x^2 / (2 sigma^2)), normalised.
std::vector<double> gaussian_taps(double sigma, int radius) {
  std::vector<double> t;
  double sum = 0.0;
  for (int x = -radius; x <= radius; ++x) {
    t.push_back(std::exp(-0.5 / (sigma * sigma) * double(x) * double(x)));
    sum += t.back();
  }
  for (double& v : t) v /= sum;
  return t;
}

// A separable 2D filter (rows with fx, then columns with fy) and its adjoint.
struct Separable {
  int width = 0, height = 0;
  Filter1D fx, fy, fx_t, fy_t;

  Separable(int w, int h, const Filter1D& x, const Filter1D& y)
      : width(w), height(h), fx(x), fy(y), fx_t(x.transposed()), fy_t(y.transposed()) {}

  static void rows(const Filter1D& f, int w, int h, const double* in, double* out) {
    tbb::parallel_for(tbb::blocked_range<int>(0, h, 16), [&](const tbb::blocked_range<int>& r) {
      for (int y = r.begin(); y < r.end(); ++y) {
        const double* src = in + size_t(y) * w;
        double* dst = out + size_t(y) * w;
        auto gather = [&](int x) {
          double s = 0.0;
          for (int k = f.start[size_t(x)]; k < f.start[size_t(x) + 1]; ++k) s += f.weight[size_t(k)] * src[f.index[size_t(k)]];
          dst[x] = s;
        };
        for (int x = 0; x < f.lo; ++x) gather(x);
        for (int x = f.hi; x < w; ++x) gather(x);
        if (f.hi > f.lo) {
          double* d = dst + f.lo;
          const int len = f.hi - f.lo;
          std::fill(d, d + len, 0.0);
          for (int m = 0; m <= 2 * f.r; ++m) {
            const double t = f.taps[size_t(m)];
            const double* s = src + (f.lo - f.r + m);
            for (int x = 0; x < len; ++x) d[x] += t * s[x];
          }
        }
      }
    });
  }
  static void cols(const Filter1D& f, int w, int h, const double* in, double* out) {
    tbb::parallel_for(tbb::blocked_range<int>(0, h, 8), [&](const tbb::blocked_range<int>& r) {
      for (int y = r.begin(); y < r.end(); ++y) {
        double* dst = out + size_t(y) * w;
        std::fill(dst, dst + w, 0.0);
        for (int k = f.start[size_t(y)]; k < f.start[size_t(y) + 1]; ++k) {
          const double* src = in + size_t(f.index[size_t(k)]) * w;
          double wk = f.weight[size_t(k)];
          for (int x = 0; x < w; ++x) dst[x] += wk * src[x];
        }
      }
    });
  }

  // out = F in (out must not alias in); tmp is scratch of the same size.
  void apply(const Plane& in, Plane& out, Plane& tmp) const {
    tmp.resize(in.size());
    out.resize(in.size());
    rows(fx, width, height, in.data(), tmp.data());
    cols(fy, width, height, tmp.data(), out.data());
  }
  // out = F^T in.
  void adjoint(const Plane& in, Plane& out, Plane& tmp) const {
    tmp.resize(in.size());
    out.resize(in.size());
    cols(fy_t, width, height, in.data(), tmp.data());
    rows(fx_t, width, height, tmp.data(), out.data());
  }
};

Separable binomial_operator(int w, int h) {
  std::vector<double> taps = {0.25, 0.5, 0.25};
  return Separable(w, h, make_filter(w, taps, clamp_index), make_filter(h, taps, clamp_index));
}

Separable ssim_window(int w, int h) {
  std::vector<double> taps = gaussian_taps(kSsimSigma, kSsimRadius);
  return Separable(w, h, make_filter(w, taps, reflect_index), make_filter(h, taps, reflect_index));
}

Plane channel_plane(const Image& img, int c) {
  Plane p(size_t(img.width) * size_t(img.height));
  for (size_t i = 0; i < p.size(); ++i) p[i] = img.pixels[i * size_t(img.channels) + size_t(c)];
  return p;
}

void check_size(const Image& a, const Image& b, const char* what_a, const char* what_b) {
  if (a.width != b.width || a.height != b.height)
    throw Error(std::string(what_a) + " is " + std::to_string(a.width) + "x" + std::to_string(a.height) + " but " +
                what_b + " is " + std::to_string(b.width) + "x" + std::to_string(b.height));
  if (a.width <= 0 || a.height <= 0) throw Error(std::string(what_a) + " is empty");
  if (a.pixels.size() != size_t(a.width) * size_t(a.height) * size_t(a.channels) || a.channels <= 0)
    throw Error(std::string(what_a) + " has inconsistent pixel storage");
  if (b.pixels.size() != size_t(b.width) * size_t(b.height) * size_t(b.channels) || b.channels <= 0)
    throw Error(std::string(what_b) + " has inconsistent pixel storage");
}

// Per-pixel mask weights (see the definitions at the top); all ones without mask.
Plane mask_weights(const Image* mask, const Image& like) {
  Plane w(size_t(like.width) * size_t(like.height), 1.0);
  if (!mask) return w;
  check_size(*mask, like, "mask", "image");
  int c;
  if (mask->channels == 1) c = 0;
  else if (mask->channels >= 4) c = 3;
  else throw Error("mask must have 1 channel or >= 4 (alpha = channel 3), got " + std::to_string(mask->channels));
  for (size_t i = 0; i < w.size(); ++i)
    w[i] = std::min(std::max(double(mask->pixels[i * size_t(mask->channels) + size_t(c)]), 0.0), 1.0);
  return w;
}

int compared_channels(const Image& a, const Image& b) { return std::min({3, a.channels, b.channels}); }

// SSIM averaging weights v_p = w_p k_p / sum(w k); all zero when the sum is zero.
Plane ssim_weights(const Plane& w, int width, int height, bool* empty) {
  int px = width > 2 * kSsimRadius ? kSsimRadius : 0;
  int py = height > 2 * kSsimRadius ? kSsimRadius : 0;
  Plane v(w.size(), 0.0);
  double sum = 0.0;
  for (int y = py; y < height - py; ++y)
    for (int x = px; x < width - px; ++x) {
      size_t i = size_t(y) * width + x;
      v[i] = w[i];
      sum += w[i];
    }
  *empty = !(sum > 0.0);
  if (*empty) std::fill(v.begin(), v.end(), 0.0);
  else for (double& e : v) e /= sum;
  return v;
}

// sum_p v_p SSIM(x, y)(p) for one channel, and (if grads) its gradients.
// Scratch planes of ssim_channel, reused across channels (no reallocation).
struct SsimScratch {
  Plane tmp, ma, mb, my, mab, myy, may, mby, prod, a_a, a_b, b, c, ga, gb, gc;
};

// The SSIM of one channel from two renders xa, xb of the same image: the local
// moments of the prediction are cross moments, mean^2 -> G(xa) G(xb) and variance
// -> G(xa xb) - G(xa) G(xb), covariance with y -> the mean of the two, so that
// for independent Monte Carlo renders no term holds a render's noise squared
// (E[cross moment] = the moment of the expected image; the plain SSIM of one
// noisy render counts its noise as contrast, and its gradient lowers the contrast
// of what is rendered). With xa == xb (the same plane) it is the plain SSIM.
//   S = A1 A2 / (B1 B2), ux = (ma + mb) / 2:
//   A1 = 2 ux uy + C1, A2 = (may + mby) - 2 ux uy + C2,
//   B1 = ma mb + uy^2 + C1, B2 = max(mab - ma mb + myy - uy^2 + C2, C2)
//   (the cross variance can be negative where the signal is flat; the clamp keeps
//   S bounded and holds that B2 fixed).
//   dS/dma = uy (A2 - A1) / D - S mb (1/B1 - 1/B2), dS/dmay = A1 / D, dS/dmab = -S / B2
//   (dS/dmb, dS/dmby alike). Gradients (if grad_a, grad_b): d/dxa sum v S =
//   G^T(v dS/dma) + xb G^T(v dS/dmab) + y G^T(v dS/dmay), and d/dxb alike.
double ssim_channel(const Separable& g, const Plane& xa, const Plane& xb, const Plane& y, const Plane& v,
                    Plane* grad_a, Plane* grad_b, SsimScratch& w) {
  const size_t n = xa.size();
  const bool same = &xa == &xb;
  Plane &tmp = w.tmp, &prod = w.prod;
  Plane &ma = w.ma, &mb = same ? w.ma : w.mb, &my = w.my, &mab = w.mab, &myy = w.myy;
  Plane &may = w.may, &mby = same ? w.may : w.mby;
  prod.resize(n);
  g.apply(xa, ma, tmp);
  if (!same) g.apply(xb, mb, tmp);
  g.apply(y, my, tmp);
  for (size_t i = 0; i < n; ++i) prod[i] = xa[i] * xb[i];
  g.apply(prod, mab, tmp);
  for (size_t i = 0; i < n; ++i) prod[i] = y[i] * y[i];
  g.apply(prod, myy, tmp);
  for (size_t i = 0; i < n; ++i) prod[i] = xa[i] * y[i];
  g.apply(prod, may, tmp);
  if (!same) {
    for (size_t i = 0; i < n; ++i) prod[i] = xb[i] * y[i];
    g.apply(prod, mby, tmp);
  }

  const bool grads = grad_a || grad_b;
  Plane &a_a = w.a_a, &a_b = w.a_b, &b = w.b, &c = w.c;
  if (grads) {
    a_a.assign(n, 0.0);
    a_b.assign(n, 0.0);
    b.assign(n, 0.0);
    c.assign(n, 0.0);
  }
  double total = 0.0;
  for (size_t i = 0; i < n; ++i) {
    if (v[i] == 0.0) continue;
    const double uy = my[i], ux = 0.5 * (ma[i] + mb[i]);
    const double A1 = 2.0 * ux * uy + kC1;
    const double A2 = (may[i] + mby[i]) - 2.0 * ux * uy + kC2;
    const double B1 = ma[i] * mb[i] + uy * uy + kC1;
    double B2 = (mab[i] - ma[i] * mb[i]) + (myy[i] - uy * uy) + kC2;
    const bool clamped = B2 < kC2;
    if (clamped) B2 = kC2;
    const double D = B1 * B2, S = A1 * A2 / D;
    total += v[i] * S;
    if (grads) {
      const double inv_b2 = clamped ? 0.0 : 1.0 / B2;
      a_a[i] = v[i] * (uy * (A2 - A1) / D - S * mb[i] * (1.0 / B1 - inv_b2));
      a_b[i] = v[i] * (uy * (A2 - A1) / D - S * ma[i] * (1.0 / B1 - inv_b2));
      b[i] = v[i] * (-S * inv_b2);
      c[i] = v[i] * (A1 / D);
    }
  }
  if (grads) {
    Plane &ga = w.ga, &gb = w.gb, &gc = w.gc;
    g.adjoint(b, gb, tmp);
    g.adjoint(c, gc, tmp);
    const auto gradient = [&](const Plane& a, const Plane& other, Plane* out) {
      g.adjoint(a, ga, tmp);
      out->resize(n);
      for (size_t i = 0; i < n; ++i) (*out)[i] = ga[i] + other[i] * gb[i] + y[i] * gc[i];
    };
    if (grad_a) gradient(a_a, xb, grad_a);
    if (grad_b) gradient(a_b, xa, grad_b);
  }
  return total;
}

Image image_like(int w, int h, int channels) {
  static const char* rgba[] = {"R", "G", "B", "A"};
  std::vector<std::string> names;
  for (int c = 0; c < channels; ++c) names.push_back(channels <= 4 ? rgba[c] : "C" + std::to_string(c));
  if (channels == 1) names = {"Y"};
  return Image(w, h, names);
}

Image apply_to_channels(const Image& image, bool adjoint) {
  if (image.width <= 0 || image.height <= 0 || image.channels <= 0 ||
      image.pixels.size() != size_t(image.width) * size_t(image.height) * size_t(image.channels))
    throw Error("binomial filter: empty image or inconsistent pixel storage");
  Separable f = binomial_operator(image.width, image.height);
  Image out = image;
  Plane res, tmp;
  for (int c = 0; c < image.channels; ++c) {
    Plane p = channel_plane(image, c);
    if (adjoint) f.adjoint(p, res, tmp);
    else f.apply(p, res, tmp);
    for (size_t i = 0; i < res.size(); ++i) out.pixels[i * size_t(image.channels) + size_t(c)] = float(res[i]);
  }
  return out;
}

}  // namespace

Image binomial_filter(const Image& image) { return apply_to_channels(image, false); }
Image binomial_filter_adjoint(const Image& d_filtered) { return apply_to_channels(d_filtered, true); }

double ssim(const Image& a, const Image& b, const Image* mask) {
  check_size(a, b, "ssim: first image", "second image");
  int nc = compared_channels(a, b);
  Plane w = mask_weights(mask, a);
  bool empty = false;
  Plane v = ssim_weights(w, a.width, a.height, &empty);
  if (empty) return 1.0;
  Separable g = ssim_window(a.width, a.height);
  double sum = 0.0;
  SsimScratch scratch;
  for (int c = 0; c < nc; ++c) {
    const Plane x = channel_plane(a, c);
    sum += ssim_channel(g, x, x, channel_plane(b, c), v, nullptr, nullptr, scratch);
  }
  return sum / nc;
}

double image_loss(const Image& pred, const Image& target, const Image* mask, const ImageLossSettings& settings,
                  Image* d_pred) {
  check_size(pred, target, "image_loss: prediction", "target");
  const int w = pred.width, h = pred.height;
  const int nc = compared_channels(pred, target);
  const size_t n = size_t(w) * size_t(h);
  const double lambda = settings.lambda_ssim;
  Plane wts = mask_weights(mask, pred);
  double wsum = 0.0;
  for (double e : wts) wsum += e;
  bool ssim_empty = false;
  Plane v = ssim_weights(wts, w, h, &ssim_empty);

  std::optional<Separable> blur;
  if (settings.binomial_filter) blur.emplace(binomial_operator(w, h));
  Separable g = ssim_window(w, h);

  double l1 = 0.0, ssim_sum = 0.0;
  if (d_pred) *d_pred = image_like(w, h, nc);
  Plane tmp;
  SsimScratch scratch;
  const auto blurred = [&](Plane p) {
    if (blur) {
      Plane bp;
      blur->apply(p, bp, tmp);
      p.swap(bp);
    }
    return p;
  };
  for (int c = 0; c < nc; ++c) {
    const Plane x = blurred(channel_plane(pred, c));
    const Plane y = settings.blur_target ? blurred(channel_plane(target, c)) : channel_plane(target, c);
    // L1 (or Huber) and its derivative.
    Plane dx(d_pred ? n : 0, 0.0);
    if (wsum > 0.0) {
      const double scale = 1.0 / (double(nc) * wsum), delta = settings.huber_delta;
      const auto dl1 = [&](double diff) {
        return std::abs(diff) < delta ? diff / delta : diff > 0.0 ? 1.0 : diff < 0.0 ? -1.0 : 0.0;
      };
      for (size_t i = 0; i < n; ++i) {
        const double diff = x[i] - y[i], a = std::abs(diff);
        l1 += wts[i] * (a < delta ? 0.5 * diff * diff / delta : a - 0.5 * delta);
        if (d_pred) dx[i] = (1.0 - lambda) * scale * wts[i] * dl1(diff);
      }
    }
    if (ssim_empty) {
      ssim_sum += 1.0;
    } else {
      // ssim_channel takes the prediction twice (its moments are written for two
      // planes); d/dx is the sum of the two derivatives.
      Plane gs[2];
      ssim_sum += ssim_channel(g, x, x, y, v, d_pred ? &gs[0] : nullptr, d_pred ? &gs[1] : nullptr, scratch);
      if (d_pred) {
        const double k_ssim = lambda / nc;
        for (size_t i = 0; i < n; ++i) dx[i] -= k_ssim * (gs[0][i] + gs[1][i]);
      }
    }
    if (!d_pred) continue;
    if (blur) {
      Plane back;
      blur->adjoint(dx, back, tmp);
      dx.swap(back);
    }
    for (size_t i = 0; i < n; ++i) d_pred->pixels[i * size_t(nc) + size_t(c)] = float(dx[i]);
  }
  double l1_mean = wsum > 0.0 ? l1 / (double(nc) * wsum) : 0.0;
  double mean_ssim = ssim_sum / nc;
  return (1.0 - lambda) * l1_mean + lambda * (1.0 - mean_ssim);
}

double edge_aware_tv(const Image& map, const Image& guide, const Image* mask, Image* d_map) {
  check_size(map, guide, "edge_aware_tv: map", "guide");
  const int w = map.width, h = map.height, mc = map.channels;
  const int gc = std::min(3, guide.channels);
  Plane wts = mask_weights(mask, map);
  if (d_map) {
    *d_map = image_like(w, h, mc);
    if (map.channel_names.size() == size_t(mc)) d_map->channel_names = map.channel_names;
  }
  std::vector<double> grad(d_map ? map.pixels.size() : 0, 0.0);
  double sum = 0.0, pair_weight = 0.0;
  auto pair = [&](int xp, int yp, int xq, int yq) {
    size_t p = size_t(yp) * w + xp, q = size_t(yq) * w + xq;
    double m = wts[p] * wts[q];
    pair_weight += m;
    if (m == 0.0) return;
    double gdiff = 0.0;
    for (int c = 0; c < gc; ++c)
      gdiff += std::abs(double(guide.pixels[p * guide.channels + c]) - double(guide.pixels[q * guide.channels + c]));
    double e = m * std::exp(-gdiff / gc);
    for (int c = 0; c < mc; ++c) {
      double d = double(map.pixels[p * mc + c]) - double(map.pixels[q * mc + c]);
      sum += e * d * d;
      if (d_map) {
        grad[p * mc + c] += 2.0 * e * d;
        grad[q * mc + c] -= 2.0 * e * d;
      }
    }
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (x + 1 < w) pair(x, y, x + 1, y);
      if (y + 1 < h) pair(x, y, x, y + 1);
    }
  if (!(pair_weight > 0.0)) return 0.0;
  if (d_map)
    for (size_t i = 0; i < grad.size(); ++i) d_map->pixels[i] = float(grad[i] / pair_weight);
  return sum / pair_weight;
}

Image chroma_guide(const Image& rgb_linear, float sharpness) {
  if (rgb_linear.channels < 3) throw Error("chroma_guide: the image needs 3 colour channels");
  const int w = rgb_linear.width, h = rgb_linear.height, ch = rgb_linear.channels;
  Image g = image_like(w, h, 3);
  for (size_t p = 0; p < size_t(w) * size_t(h); ++p) {
    float c[3], sum = kChromaGuideEps;
    for (int k = 0; k < 3; ++k) sum += c[k] = std::max(0.0f, rgb_linear.pixels[p * ch + k]);
    for (int k = 0; k < 3; ++k) g.pixels[p * 3 + k] = sharpness * c[k] / sum;
  }
  return g;
}

double prior_l2(const Image& map, const Image& prior, const Image* mask, Image* d_map) {
  check_size(map, prior, "prior_l2: map", "prior");
  const int w = map.width, h = map.height, mc = map.channels;
  const int nc = std::min(map.channels, prior.channels);
  const size_t n = size_t(w) * size_t(h);
  Plane wts = mask_weights(mask, map);
  double wsum = 0.0;
  for (double e : wts) wsum += e;
  if (d_map) {
    *d_map = image_like(w, h, mc);
    if (map.channel_names.size() == size_t(mc)) d_map->channel_names = map.channel_names;
  }
  if (!(wsum > 0.0)) return 0.0;
  double scale = 1.0 / (double(nc) * wsum), sum = 0.0;
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < nc; ++c) {
      double d = double(map.pixels[i * mc + c]) - double(prior.pixels[i * prior.channels + c]);
      sum += wts[i] * d * d;
      if (d_map) d_map->pixels[i * mc + c] = float(2.0 * scale * wts[i] * d);
    }
  return sum * scale;
}

}  // namespace ptir
