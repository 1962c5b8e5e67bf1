// Densification and pruning of the geometry stage (geometry_fit.h, step 5).
//
// Bounded, as the issue asks: pruning first (opacity < prune_opacity), then the
// Gaussians whose mean positional gradient exceeds densify_grad, largest first,
// at most densify_fraction of the count per step and never beyond max_gaussians.
// Small ones are cloned (the copy starts with zero Adam moments), large ones
// (largest scale > split_scale x the cameras' extent) split into two children
// drawn from the parent, scales / 1.6 (3DGS). Statistics restart after each step.
#include <algorithm>
#include <cmath>

#include "ptir/math/rng.h"
#include "ptir/optim/geometry_fit.h"
#include "ptir/optim/geometry_fit_groups.h"

namespace ptir {

namespace {

template <class T>
std::vector<T> gather(const std::vector<T>& v, const std::vector<uint32_t>& src) {
  std::vector<T> out;
  if (v.empty()) return out;
  out.reserve(src.size());
  for (uint32_t i : src) out.push_back(v[i]);
  return out;
}

// Rows of a per-Gaussian vector of `width` floats; rows where `fresh` is set are zero.
std::vector<float> gather_rows(const std::vector<float>& v, int width, const std::vector<uint32_t>& src,
                               const std::vector<uint8_t>* fresh) {
  std::vector<float> out(src.size() * size_t(width), 0.0f);
  for (size_t j = 0; j < src.size(); ++j) {
    if (fresh && (*fresh)[j]) continue;
    std::copy_n(v.begin() + long(src[j]) * width, width, out.begin() + long(j) * width);
  }
  return out;
}

}  // namespace

void GeometryFit::densify(int it, FitLog& log) {
  const size_t n = field_.size();
  std::vector<uint32_t> kept;
  for (uint32_t i = 0; i < n; ++i)
    if (field_.opacity[i] >= settings_.prune_opacity) kept.push_back(i);
  log.pruned = int(n - kept.size());

  // Candidates by mean gradient, largest first (ties by index: deterministic).
  std::vector<std::pair<float, uint32_t>> cand;
  for (uint32_t i : kept) {
    const float mean = grad_count_[i] > 0 ? grad_accum_[i] / grad_count_[i] : 0.0f;
    if (mean > settings_.densify_grad) cand.push_back({-mean, i});
  }
  std::sort(cand.begin(), cand.end());
  const size_t room = settings_.max_gaussians > kept.size() ? settings_.max_gaussians - kept.size() : 0;
  const size_t budget = std::min(room, size_t(std::floor(settings_.densify_fraction * float(n))));
  if (cand.size() > budget) cand.resize(budget);

  // New rows: kept ones (a split parent becomes its first child), then the added ones.
  std::vector<uint8_t> grows(n, 0);  // 1 clone, 2 split
  for (const auto& c : cand) {
    const Vec3 s = field_.scale[c.second];
    grows[c.second] = std::max({s.x, s.y, s.z}) > settings_.split_scale * extent_ ? 2 : 1;
  }
  std::vector<uint32_t> src = kept;
  for (const auto& c : cand) src.push_back(c.second);
  std::vector<uint8_t> fresh(src.size(), 0);
  std::fill(fresh.begin() + long(kept.size()), fresh.end(), 1);

  const int stride = field_.sh_stride();
  for (int k = 0; k < kFitGroups; ++k) {
    const int w = fit_group_width(k, stride);
    groups_[k].raw = gather_rows(groups_[k].raw, w, src, nullptr);
    adam_[k].m = gather_rows(adam_[k].m, w, src, &fresh);
    adam_[k].v = gather_rows(adam_[k].v, w, src, &fresh);
  }
  // Split children: positions drawn from the parent, scales / 1.6.
  const float shrink = std::log(1.6f);
  for (size_t j = 0; j < src.size(); ++j) {
    const uint32_t parent = src[j];
    if (grows[parent] != 2) continue;
    log.split += j >= kept.size();
    Rng rng(settings_.seed, uint64_t(it), uint64_t(parent) * 2 + (j >= kept.size()));
    const Mat3 r = field_.rotation_matrix(parent);
    Vec3 z;
    for (int c = 0; c < 3; ++c) {  // Box-Muller
      const float u1 = std::max(rng.next(), 1e-7f), u2 = rng.next();
      z[c] = std::sqrt(-2.0f * std::log(u1)) * std::cos(6.2831853f * u2);
    }
    const Vec3 s = field_.scale[parent];
    const Vec3 offset = r * Vec3(z.x * s.x, z.y * s.y, z.z * s.z);
    for (int c = 0; c < 3; ++c) {
      groups_[kFitPosition].raw[3 * j + c] = field_.position[parent][c] + offset[c];
      groups_[kFitLogScale].raw[3 * j + c] -= shrink;
    }
  }
  log.cloned = int(cand.size()) - log.split;
  // The material columns follow their Gaussians.
  field_.albedo = gather(field_.albedo, src);
  field_.roughness = gather(field_.roughness, src);
  field_.metallic = gather(field_.metallic, src);
  field_.specular = gather(field_.specular, src);
  field_.specular_tint = gather(field_.specular_tint, src);
  grad_accum_.assign(src.size(), 0.0f);
  grad_count_.assign(src.size(), 0.0f);
}

}  // namespace ptir
