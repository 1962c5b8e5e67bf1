// Virtual cameras around a splat object (orbit_views.h).
#include "ptir/scene/orbit_views.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <numeric>

#include "ptir/core/error.h"

namespace ptir {

namespace {

constexpr float kDeg = 3.14159265358979f / 180.0f;
constexpr float kMinOpacity = 0.05f;  // fainter splats (haze, floaters' fringes) do not bound the object

// The value below which `fraction` of the total weight lies.
float weighted_quantile(std::vector<std::pair<float, float>> vw, float fraction) {
  std::sort(vw.begin(), vw.end());
  double total = 0;
  for (const auto& p : vw) total += p.second;
  double acc = 0;
  for (const auto& p : vw) {
    acc += p.second;
    if (acc >= fraction * total) return p.first;
  }
  return vw.back().first;
}

// The 1st..99th opacity-weighted percentile range of the splats' positions along `axis`.
float robust_extent_along(const GaussianField& field, Vec3 axis) {
  std::vector<std::pair<float, float>> vw;
  for (size_t i = 0; i < field.size(); ++i)
    if (field.opacity[i] >= kMinOpacity && is_finite(field.position[i]))
      vw.emplace_back(dot(field.position[i], axis), field.opacity[i]);
  return vw.empty() ? 0.0f : weighted_quantile(vw, 0.99f) - weighted_quantile(vw, 0.01f);
}

// Cameras stand up to ~130 radii away (a 1 degree field of view): their squared
// distances must stay finite in float (3.4e38), with room to spare.
constexpr float kMaxOrbitRadius = 1e15f;

std::string text(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g", v);
  return b;
}

std::string text(Vec3 v) { return "(" + text(v.x) + ", " + text(v.y) + ", " + text(v.z) + ")"; }

// Why the robust sphere is too large: its positions (a floater the percentiles
// keep: with under 100 splats they are the extremes) or the splats' own size.
std::string too_large_to_orbit(const SplatBounds& b, float splat) {
  const std::string tail = ": too large to place cameras around (the limit is a radius of " + text(kMaxOrbitRadius) + ")";
  if (!(3.0f * splat <= 0.5f * kMaxOrbitRadius))
    return "the splats' median largest scale is " + text(splat) + " (log-scale " + text(std::log(double(splat))) + ")" +
           tail;
  return "the splats' positions span " + text(b.lo) + " to " + text(b.hi) + " (the 1st and 99th opacity-weighted " +
         "percentiles of " + std::to_string(b.counted) + " splats; a floater far from the others?)" + tail;
}

}  // namespace

SplatBounds robust_splat_bounds(const GaussianField& field) {
  std::vector<size_t> kept;
  for (size_t i = 0; i < field.size(); ++i)
    if (field.opacity[i] >= kMinOpacity && is_finite(field.position[i])) kept.push_back(i);
  if (kept.empty())
    throw Error(field.source_path.empty() ? "gaussians" : field.source_path,
                "no splat has opacity >= 0.05: nothing to place cameras around");
  SplatBounds b;
  b.counted = kept.size();
  // Per axis: the 1st and 99th opacity-weighted percentiles (floaters trimmed).
  for (int a = 0; a < 3; ++a) {
    std::vector<std::pair<float, float>> vw;
    vw.reserve(kept.size());
    for (size_t i : kept) vw.emplace_back(field.position[i][a], field.opacity[i]);
    b.lo[a] = weighted_quantile(vw, 0.01f);
    b.hi[a] = weighted_quantile(vw, 0.99f);
  }
  b.centre = 0.5f * (b.lo + b.hi);
  // The sphere: 99th weighted percentile of the in-box splats' distances, plus
  // 3 sigma of their median largest scale.
  std::vector<std::pair<float, float>> dist, size;
  for (size_t i : kept) {
    const Vec3 p = field.position[i];
    if (p.x < b.lo.x || p.y < b.lo.y || p.z < b.lo.z || p.x > b.hi.x || p.y > b.hi.y || p.z > b.hi.z) continue;
    dist.emplace_back(length(p - b.centre), field.opacity[i]);
    size.emplace_back(max_component(field.scale[i]), 1.0f);
  }
  if (dist.empty()) {  // every splat on a box face of zero extent: a single point
    dist.emplace_back(0.0f, 1.0f);
    size.emplace_back(max_component(field.scale[kept[0]]), 1.0f);
  }
  const float spread = weighted_quantile(dist, 0.99f), splat = weighted_quantile(size, 0.5f);
  b.radius = spread + 3.0f * splat;
  const std::string source = field.source_path.empty() ? "gaussians" : field.source_path;
  if (!(b.radius <= kMaxOrbitRadius)) throw Error(source, too_large_to_orbit(b, splat));
  if (!(b.radius > 0)) throw Error(source, "the splats have no extent to orbit (every one at one point, of zero size)");
  return b;
}

void horizontal_axes(Vec3 up, Vec3* e1, Vec3* e2) {
  // World x projected off up (world y where up is along x).
  const Vec3 ref = std::fabs(up.x) < 0.9f ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
  *e1 = normalize(ref - dot(ref, up) * up);
  *e2 = cross(up, *e1);
}

Affine look_at(Vec3 eye, Vec3 target, Vec3 up) {
  const Vec3 back = normalize(eye - target);
  Vec3 right = cross(up, back);
  if (length(right) < 1e-6f) {  // straight above or below: any horizontal right
    Vec3 e2;
    horizontal_axes(up, &right, &e2);
  }
  right = normalize(right);
  const Vec3 image_up = cross(back, right);
  Affine a;
  a.linear = Mat3::from_cols(right, image_up, back);
  a.translation = eye;
  return a;
}

OrbitPlan plan_orbit(const GaussianField& field, const OrbitOptions& o) {
  OrbitPlan plan;
  plan.bounds = robust_splat_bounds(field);
  const double n = double(std::max<size_t>(field.size(), 1));
  plan.size = o.size > 0 ? o.size : std::clamp(16 * int(std::lround(std::sqrt(n) / 20.0)), 256, 640);
  plan.views = o.views > 0 ? o.views : std::clamp(int(std::lround(24.0 + 8.0 * std::log2(n / 1e4))), 24, 96);
  if (!(is_finite(o.up) && std::fabs(length(o.up) - 1.0f) < 1e-3f)) throw Error("the orbit's up axis must be a unit vector");
  plan.up = o.up;
  Vec3 e1, e2;
  horizontal_axes(o.up, &e1, &e2);
  const Vec3 ext = plan.bounds.hi - plan.bounds.lo;
  const bool z_up = o.up.x == 0 && o.up.y == 0 && o.up.z == 1;  // the box's own extents
  const bool flat = z_up ? ext.z < 0.25f * std::max(ext.x, ext.y)
                         : robust_extent_along(field, o.up) <
                               0.25f * std::max(robust_extent_along(field, e1), robust_extent_along(field, e2));
  plan.elevation_min = o.elevation_min > -999 ? o.elevation_min : (flat ? 10.0f : -30.0f);
  plan.elevation_max = o.elevation_max > -999 ? o.elevation_max : 75.0f;
  if (!(plan.elevation_min <= plan.elevation_max) || plan.elevation_min < -90 || plan.elevation_max > 90)
    throw Error("the orbit's elevation range must be MIN <= MAX within [-90, 90] degrees");
  if (!(o.fov_deg > 1 && o.fov_deg < 170)) throw Error("the orbit's field of view must be in (1, 170) degrees");
  if (plan.size < 16 || plan.size > 8192) throw Error("the orbit's image size must be 16..8192 pixels");
  if (plan.views < 1 || plan.views > 10000) throw Error("the orbit's view count must be 1..10000");
  plan.fov_deg = o.fov_deg;
  const float half = 0.5f * o.fov_deg * kDeg;
  plan.distance = plan.bounds.radius / std::sin(half) * 1.15f * o.distance_scale;
  if (!(std::fabs(plan.distance) <= 1e18f))
    throw Error("the orbit's distance " + text(plan.distance) + " (radius " + text(plan.bounds.radius) +
                " x --orbit-distance " + text(o.distance_scale) + ") is out of range: place cameras with --cameras");
  // Golden-angle spiral, uniform in sin(elevation) over the range.
  const float s0 = std::sin(plan.elevation_min * kDeg), s1 = std::sin(plan.elevation_max * kDeg);
  const float golden = 180.0f * kDeg * (3.0f - std::sqrt(5.0f));
  for (int k = 0; k < plan.views; ++k) {
    const float s = s0 + (s1 - s0) * (float(k) + 0.5f) / float(plan.views);
    const float c = std::sqrt(std::max(0.0f, 1.0f - s * s)), phi = golden * float(k);
    const Vec3 eye = plan.bounds.centre + plan.distance * (c * std::cos(phi) * e1 + c * std::sin(phi) * e2 + s * o.up);
    const Affine a = look_at(eye, plan.bounds.centre, o.up);
    float m[16] = {0};
    for (int r = 0; r < 3; ++r) {
      for (int col = 0; col < 3; ++col) m[r * 4 + col] = a.linear.m[r][col];
      m[r * 4 + 3] = a.translation[r];
    }
    m[15] = 1;
    char name[32];
    std::snprintf(name, sizeof name, "orbit_%03d", k);
    plan.cameras.push_back(make_camera(m, 2 * half, plan.size, plan.size, name));
  }
  return plan;
}

std::string orbit_plan_json(const OrbitPlan& plan, const std::string& source) {
  nlohmann::json j;
  j["source"] = source;
  const auto v3 = [](Vec3 v) { return nlohmann::json::array({v.x, v.y, v.z}); };
  j["bounds"] = {{"lo", v3(plan.bounds.lo)}, {"hi", v3(plan.bounds.hi)}, {"centre", v3(plan.bounds.centre)},
                 {"radius", plan.bounds.radius}, {"splats_counted", plan.bounds.counted}};
  j["views"] = plan.views;
  j["size"] = plan.size;
  j["elevation_deg"] = {plan.elevation_min, plan.elevation_max};
  j["up"] = v3(plan.up);
  j["fov_deg"] = plan.fov_deg;
  j["distance"] = plan.distance;
  nlohmann::json frames = nlohmann::json::array();
  for (const Camera& c : plan.cameras) {
    nlohmann::json m = nlohmann::json::array();
    for (int r = 0; r < 3; ++r)
      m.push_back({c.cam_to_world.linear.m[r][0], c.cam_to_world.linear.m[r][1], c.cam_to_world.linear.m[r][2],
                   c.cam_to_world.translation[r]});
    m.push_back({0, 0, 0, 1});
    frames.push_back({{"name", c.name}, {"transform_matrix", m}, {"fl_x", c.fx}, {"fl_y", c.fy}, {"cx", c.cx},
                      {"cy", c.cy}, {"w", c.width}, {"h", c.height}});
  }
  j["cameras"] = frames;
  return j.dump(1);
}

}  // namespace ptir
