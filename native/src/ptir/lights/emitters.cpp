#include "ptir/lights/emitters.h"

#include <cmath>

#include "ptir/lights/light_units.h"

namespace ptir {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Shirley-Chiu concentric map of [0,1)^2 onto the unit disc (area preserving).
void concentric_disc(float u0, float u1, float* x, float* y) {
  float a = 2.0f * u0 - 1.0f, b = 2.0f * u1 - 1.0f;
  if (a == 0.0f && b == 0.0f) {
    *x = *y = 0.0f;
    return;
  }
  float r, phi;
  if (std::fabs(a) > std::fabs(b)) {
    r = a;
    phi = (kPi / 4.0f) * (b / a);
  } else {
    r = b;
    phi = (kPi / 2.0f) - (kPi / 4.0f) * (a / b);
  }
  *x = r * std::cos(phi);
  *y = r * std::sin(phi);
}

}  // namespace

// ---------------------------------------------------------------- point

PointLight PointLight::from_blender(Vec3 position, float watts, Vec3 colour, float radius) {
  return PointLight(position, blender_units::point_intensity(watts, colour), radius);
}

Vec3 PointLight::radiance() const {
  return radius > 0.0f ? intensity / (kPi * radius * radius) : Vec3(0.0f);
}

LightSample PointLight::sample_li(Vec3 p, float u0, float u1) const {
  LightSample s;
  Vec3 to_p = p - position;
  float d2 = length_sq(to_p);
  if (!(d2 > 0.0f)) return s;
  if (is_delta()) {
    float d = std::sqrt(d2);
    s.wi = (position - p) / d;
    s.distance = d;
    s.Li = intensity / d2;
    s.pdf = 1.0f;
    s.delta = true;
    return s;
  }
  // Disc facing p (Cycles 3.4): normal n_l from the centre toward p.
  Frame f(to_p / std::sqrt(d2));
  float dx, dy;
  concentric_disc(u0, u1, &dx, &dy);
  Vec3 q = position + (f.s * dx + f.t * dy) * radius;
  Vec3 w = q - p;
  float t2 = length_sq(w);
  float t = std::sqrt(t2);
  s.wi = w / t;
  float cos_l = -dot(s.wi, f.n);
  if (!(cos_l > 0.0f) || !(t > 0.0f)) return s;
  s.distance = t;
  s.Li = radiance();
  s.pdf = t2 / (cos_l * kPi * radius * radius);
  return s;
}

bool PointLight::hit(const Ray& ray, LightHit* out) const {
  if (is_delta()) return false;
  Vec3 to_o = ray.o - position;
  float d2 = length_sq(to_o);
  if (!(d2 > 0.0f)) return false;
  Vec3 n = to_o / std::sqrt(d2);  // disc faces the ray origin
  float denom = dot(ray.d, n);
  if (!(denom < 0.0f)) return false;
  float t = dot(position - ray.o, n) / denom;
  if (!(t > ray.tmin && t < ray.tmax)) return false;
  Vec3 q = ray.at(t);
  if (length_sq(q - position) > radius * radius) return false;
  float cos_l = -denom / length(ray.d);
  float dist = t * length(ray.d);
  out->t = t;
  out->Le = radiance();
  out->pdf = dist * dist / (cos_l * kPi * radius * radius);
  return true;
}

float PointLight::pdf(Vec3 p, Vec3 wi) const {
  LightHit h;
  Ray r{p, normalize(wi)};
  return hit(r, &h) ? h.pdf : 0.0f;
}

// ---------------------------------------------------------------- sun

SunLight::SunLight(Vec3 to_sun_, Vec3 irradiance_, float angle_)
    : to_sun(normalize(to_sun_)), irradiance(irradiance_), angle(angle_) {
  if (angle > 0.0f) {
    const float half = 0.5f * angle;
    cos_half_ = std::cos(half);
    tan_half_ = std::tan(half);
    invarea_ = blender_units::sun_invarea(angle);
  }
}

SunLight SunLight::from_blender(Vec3 object_z_axis, float strength, Vec3 colour, float angle) {
  return SunLight(object_z_axis, colour * blender_units::sun_irradiance(strength), angle);
}

LightSample SunLight::sample_li(Vec3 p, float u0, float u1) const {
  LightSample s;
  s.distance = kInf;
  if (is_delta()) {
    s.wi = to_sun;
    s.Li = irradiance;
    s.pdf = 1.0f;
    s.delta = true;
    return s;
  }
  Frame f(to_sun);
  float dx, dy;
  concentric_disc(u0, u1, &dx, &dy);
  s.wi = normalize(to_sun + (f.s * dx + f.t * dy) * tan_half_);
  float c = dot(s.wi, to_sun);
  if (!(c > 0.0f)) return s;
  float w = invarea_ / (c * c * c);
  s.Li = irradiance * w;
  s.pdf = w;
  return s;
}

float SunLight::pdf(Vec3 p, Vec3 wi) const {
  if (is_delta()) return 0.0f;
  float c = dot(normalize(wi), to_sun);
  if (!(c >= cos_half_) || !(c > 0.0f)) return 0.0f;
  return invarea_ / (c * c * c);
}

bool SunLight::hit(const Ray& ray, LightHit* out) const {
  if (is_delta() || ray.tmax < kInf) return false;
  float pd = pdf(ray.o, ray.d);
  if (!(pd > 0.0f)) return false;
  out->t = kInf;
  out->Le = irradiance * pd;
  out->pdf = pd;
  return true;
}

// ---------------------------------------------------------------- area

AreaLight::AreaLight(AreaShape shape_, Vec3 center_, Vec3 axis_u_, Vec3 axis_v_, float size_u_, float size_v_,
                     Vec3 radiance_)
    : shape(shape_), center(center_), axis_u(normalize(axis_u_)), axis_v(normalize(axis_v_)),
      size_u(size_u_), size_v(size_v_), radiance(radiance_) {
  normal = -normalize(cross(axis_u, axis_v));
}

AreaLight AreaLight::from_blender(const Affine& m, AreaShape shape, float size_x, float size_y, float watts,
                                  Vec3 colour) {
  // Cycles: extent = object axis (with scale) * size; area = |extent_u| |extent_v|
  // (times pi/4 for ellipses); emission direction = -(object z axis).
  Vec3 eu = m.linear.col(0) * size_x, ev = m.linear.col(1) * size_y;
  float lu = length(eu), lv = length(ev);
  AreaLight l;
  l.shape = shape;
  l.center = m.translation;
  l.axis_u = eu / lu;
  l.axis_v = ev / lv;
  l.size_u = lu;
  l.size_v = lv;
  l.normal = -normalize(m.linear.col(2));
  float a = l.area();
  l.radiance = blender_units::area_radiance(watts, a, colour);
  return l;
}

float AreaLight::area() const {
  return shape == AreaShape::Rectangle ? blender_units::rect_area(size_u, size_v)
                                       : blender_units::ellipse_area(size_u, size_v);
}

LightSample AreaLight::sample_li(Vec3 p, float u0, float u1) const {
  LightSample s;
  if (!(dot(p - center, normal) > 0.0f)) return s;  // behind (or in) the emitting plane
  float a, b;
  if (shape == AreaShape::Rectangle) {
    a = (u0 - 0.5f) * size_u;
    b = (u1 - 0.5f) * size_v;
  } else {
    concentric_disc(u0, u1, &a, &b);
    a *= 0.5f * size_u;
    b *= 0.5f * size_v;
  }
  Vec3 q = center + axis_u * a + axis_v * b;
  Vec3 w = q - p;
  float d2 = length_sq(w);
  float d = std::sqrt(d2);
  if (!(d > 0.0f)) return s;
  s.wi = w / d;
  float cos_l = -dot(s.wi, normal);
  if (!(cos_l > 0.0f)) return s;
  s.distance = d;
  s.Li = radiance;
  s.pdf = d2 / (area() * cos_l);
  return s;
}

bool AreaLight::hit(const Ray& ray, LightHit* out) const {
  float denom = dot(ray.d, normal);
  if (!(denom < 0.0f)) return false;  // parallel or hitting the back: no emission
  float t = dot(center - ray.o, normal) / denom;
  if (!(t > ray.tmin && t < ray.tmax)) return false;
  Vec3 q = ray.at(t) - center;
  float a = dot(q, axis_u), b = dot(q, axis_v);
  if (shape == AreaShape::Rectangle) {
    if (std::fabs(a) > 0.5f * size_u || std::fabs(b) > 0.5f * size_v) return false;
  } else {
    float x = a / (0.5f * size_u), y = b / (0.5f * size_v);
    if (x * x + y * y > 1.0f) return false;
  }
  float len_d = length(ray.d);
  float cos_l = -denom / len_d;
  float dist = t * len_d;
  out->t = t;
  out->Le = radiance;
  out->pdf = dist * dist / (area() * cos_l);
  return true;
}

float AreaLight::pdf(Vec3 p, Vec3 wi) const {
  LightHit h;
  Ray r{p, normalize(wi)};
  return hit(r, &h) ? h.pdf : 0.0f;
}

// ---------------------------------------------------------------- dispatch

bool is_delta(const Emitter& e) {
  return std::visit([](const auto& l) { return l.is_delta(); }, e);
}

LightSample sample_li(const Emitter& e, Vec3 p, float u0, float u1) {
  return std::visit([&](const auto& l) { return l.sample_li(p, u0, u1); }, e);
}

float light_pdf(const Emitter& e, Vec3 p, Vec3 wi) {
  return std::visit([&](const auto& l) { return l.pdf(p, wi); }, e);
}

bool light_hit(const Emitter& e, const Ray& ray, LightHit* out) {
  return std::visit([&](const auto& l) { return l.hit(ray, out); }, e);
}

}  // namespace ptir
