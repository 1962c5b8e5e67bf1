#include "ptir/transport/interaction.h"

namespace ptir {

bool InteractionBuilder::add(const GaussianHit& hit) {
  float w = T_ * hit.alpha;
  const float O_before = O_;
  O_ += w;
  hits_++;
  if (record_) record_->push_back({hit.id, w});
  if (settings_.mode == InteractionMode::Aggregate) {
    // Running weighted sums; normalised by O in finish(). The depth: where O
    // first reaches 1/2 (the mean only as a fallback).
    sum_t_ += w * hit.t;
    if (median_t_ < 0.0f && O_ >= 0.5f) median_t_ = hit.t;
    // Normals without a sign from the file (a trainer's PLY: the shortest axis) are
    // two-sided: each on the side of the interaction so far, seen from the ray (ref =
    // sum w_j n_j - O d / 2; the first hit: -d), so that neighbours whose guessed
    // signs disagree reinforce instead of cancelling, a surface's normals stay
    // consistent where they graze the ray, and a hit across them (a crease) faces the
    // ray: their guessed signs never matter. Normals the file gives keep their sign:
    // a far side seen through the near one (thin or unsaturated layers) then pulls
    // the aggregate less than its mirror image would (sphere-grid twin against Cycles
    // 3.4, inside the silhouettes: 33.61 dB signed, 32.00 dB two-sided).
    const Vec3 n = field_.normal[hit.id];
    if (field_.normals_from_file) {
      sum_n_ += w * n;
    } else {
      const Vec3 ref = hits_ == 1 ? -incoming_ : sum_n_ - (0.5f * O_before) * incoming_;
      sum_n_ += dot(n, ref) < 0.0f ? -w * n : w * n;
    }
    sum_a_ += w * field_.albedo[hit.id];
    sum_r_ += w * field_.roughness[hit.id];
    sum_m_ += w * field_.metallic[hit.id];
    if (!field_.specular.empty()) sum_s_ += w * field_.specular[hit.id];
    if (!field_.specular_tint.empty()) sum_st_ += w * field_.specular_tint[hit.id];
    sum_size_ += w * max_component(field_.scale[hit.id]);
    if (radiance_) sum_rad_ += w * radiance_[hit.id];
  } else {
    // Weighted reservoir of size one: hit j survives with probability w_j / O.
    if (pick_rng_.at(hits_) * O_ < w) {
      picked_ = hit.id;
      picked_t_ = hit.t;
    }
  }
  T_ *= 1.0f - hit.alpha;
  return T_ >= min_transmittance_;
}

SurfaceInteraction InteractionBuilder::finish(const Ray& ray) const {
  SurfaceInteraction si;
  si.opacity = O_;
  si.transmittance = T_;
  si.hits = hits_;
  si.valid = O_ > settings_.tau_g;
  if (!(O_ > 0.0f)) return si;
  Vec3 n;
  if (settings_.mode == InteractionMode::Aggregate) {
    float inv = 1.0f / O_;
    si.depth = median_t_ >= 0.0f ? median_t_ : sum_t_ * inv;
    n = sum_n_;
    si.albedo = sum_a_ * inv;
    si.roughness = sum_r_ * inv;
    si.metallic = sum_m_ * inv;
    si.specular = field_.specular.empty() ? kDefaultSpecular : sum_s_ * inv;
    si.specular_tint = field_.specular_tint.empty() ? kDefaultSpecularTint : sum_st_ * inv;
    si.size = sum_size_ * inv;
    si.radiance = sum_rad_ * inv;
  } else {
    si.picked = picked_;
    si.depth = picked_t_;
    n = field_.normal[picked_];
    si.albedo = field_.albedo[picked_];
    si.roughness = field_.roughness[picked_];
    si.metallic = field_.metallic[picked_];
    si.specular = field_.specular_of(picked_);
    si.specular_tint = field_.specular_tint_of(picked_);
    si.size = max_component(field_.scale[picked_]);
    if (radiance_) si.radiance = radiance_[picked_];
  }
  si.p = ray.at(si.depth);
  // Normal rule: normalise the aggregate (of normals already facing the ray) or
  // take the picked hit's, and flip it to face the incoming ray, so a surface is
  // shaded from the side it is seen from. A vanishing aggregate falls back to -d.
  n = normalize(n);
  if (length_sq(n) == 0.0f) n = -ray.d;
  if (dot(n, ray.d) > 0.0f) n = -n;
  si.n = n;
  return si;
}

}  // namespace ptir
