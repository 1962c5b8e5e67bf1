// Analytic emitters: point, sun, and rectangle/ellipse(disc) area lights, with
// the sampling, density and ray-hit queries needed for next-event estimation with
// MIS. Units and shapes follow Cycles 3.4 (see light_units.h); from_blender()
// converts a Blender light's settings exactly as Cycles does.
//
// Conventions
// - sample_li(p, u0, u1) returns the direction wi from p toward the light, the
//   distance to the sampled point (infinity for the sun), the radiance Li arriving
//   along wi, and the solid-angle pdf of wi. For delta lights (point radius 0, sun
//   angle 0) `delta` is set, pdf = 1 and Li is the delta's contribution
//   (I / d^2 for a point light, the irradiance E for the sun): the estimate is
//   f * Li * cos / pdf as for any other light, and MIS does not apply.
//   An invalid sample has pdf 0 (p behind a one-sided light, p at the light, ...).
// - pdf(p, wi) is the solid-angle density of sample_li(p, .) producing wi (0 for
//   delta lights or when the ray misses), and hit(ray, &h) intersects a ray with
//   the light (area lights are not in the Embree scene): h.t, the emitted radiance
//   h.Le toward the ray origin, and h.pdf = pdf(ray.o, ray.d), for MIS on a
//   BSDF-sampled ray. Lights do not occlude anything.
// - Area lights are one-sided like Blender's: they emit along `normal`, the
//   object's local -z. A hit from behind is no hit.
#pragma once

#include <limits>
#include <variant>

#include "ptir/math/ray.h"
#include "ptir/math/vec.h"

namespace ptir {

struct LightSample {
  Vec3 wi;                                                  // unit, from p toward the light
  float distance = std::numeric_limits<float>::infinity();  // to the sampled point
  Vec3 Li;                                                  // radiance (or delta contribution)
  float pdf = 0.0f;                                         // solid angle; 1 for delta lights
  bool delta = false;
  bool valid() const { return pdf > 0.0f; }
};

struct LightHit {
  float t = std::numeric_limits<float>::infinity();
  Vec3 Le;          // radiance emitted toward the ray origin
  float pdf = 0.0f; // solid-angle density of light sampling producing this direction
};

// Point light of radiant intensity I (W/sr). With radius r > 0 it is, as in
// Cycles 3.4, a disc of radius r centred on `position` and facing the shading
// point (for sampling and for hits alike), of radiance I / (pi r^2), sampled
// uniformly by area: pdf = d^2 / (pi r^2 cos). (Cycles intersects BSDF rays with a
// disc facing the ray instead; the two agree to O(r^2 / d^2).)
struct PointLight {
  Vec3 position;
  Vec3 intensity;     // W/sr, RGB
  float radius = 0.0f;

  PointLight() = default;
  PointLight(Vec3 position_, Vec3 intensity_, float radius_ = 0.0f)
      : position(position_), intensity(intensity_), radius(radius_) {}
  // Blender: Power `watts`, Color `colour`, Radius (shadow_soft_size) `radius`.
  static PointLight from_blender(Vec3 position, float watts, Vec3 colour = Vec3(1.0f), float radius = 0.0f);

  bool is_delta() const { return !(radius > 0.0f); }
  Vec3 radiance() const;  // of the disc (radius > 0)
  LightSample sample_li(Vec3 p, float u0, float u1) const;
  float pdf(Vec3 p, Vec3 wi) const;
  bool hit(const Ray& ray, LightHit* out) const;
};

// Sun (distant) light. `to_sun`: unit direction from the scene toward the sun;
// `irradiance`: W/m^2 on a surface facing it (Blender's Strength * Color).
// angle > 0 (full apparent diameter, radians): directions within angle/2 of
// to_sun, radiance E invarea / cos^3(theta), invarea = 1/(pi tan^2(angle/2)),
// sampled like Cycles (a disc of radius tan(angle/2) at unit distance), so
// Li / pdf = E for every sample.
struct SunLight {
  Vec3 to_sun{0, 0, 1};
  Vec3 irradiance;
  float angle = 0.0f;

  SunLight() = default;
  SunLight(Vec3 to_sun_, Vec3 irradiance_, float angle_ = 0.0f);
  // Blender: the sun shines along the object's local -z, so to_sun = +z column of
  // the object's world matrix (`object_z_axis`, normalised here).
  static SunLight from_blender(Vec3 object_z_axis, float strength, Vec3 colour = Vec3(1.0f), float angle = 0.0f);

  bool is_delta() const { return !(angle > 0.0f); }
  LightSample sample_li(Vec3 p, float u0, float u1) const;
  float pdf(Vec3 p, Vec3 wi) const;
  // Hits only rays that reach infinity (ray.tmax = inf) inside the sun's cone.
  bool hit(const Ray& ray, LightHit* out) const;

 private:
  float cos_half_ = 1.0f, tan_half_ = 0.0f, invarea_ = 1.0f;
};

enum class AreaShape { Rectangle, Ellipse };  // Blender SQUARE/RECTANGLE, DISK/ELLIPSE

// One-sided area light of uniform radiance, sampled uniformly by area:
// pdf = d^2 / (A cos(theta_light)).
struct AreaLight {
  AreaShape shape = AreaShape::Rectangle;
  Vec3 center;
  Vec3 axis_u{1, 0, 0}, axis_v{0, 1, 0};  // unit in-plane axes (the object's local x, y)
  float size_u = 1.0f, size_v = 1.0f;     // full extents (ellipse: diameters)
  Vec3 normal{0, 0, -1};                  // emission direction (local -z)
  Vec3 radiance;                          // W/(m^2 sr), RGB

  AreaLight() = default;
  // normal = -normalize(cross(axis_u, axis_v)) (Blender's local -z).
  AreaLight(AreaShape shape_, Vec3 center_, Vec3 axis_u_, Vec3 axis_v_, float size_u_, float size_v_,
            Vec3 radiance_);
  // Blender area light with the object's world matrix (scale included, no shear):
  // Size (size_x), Size Y (size_y; = size_x for SQUARE/DISK), Power, Color.
  // Radiance = colour * watts / (4 * area), as Cycles.
  static AreaLight from_blender(const Affine& object_to_world, AreaShape shape, float size_x, float size_y,
                                float watts, Vec3 colour = Vec3(1.0f));

  bool is_delta() const { return false; }
  float area() const;
  LightSample sample_li(Vec3 p, float u0, float u1) const;
  float pdf(Vec3 p, Vec3 wi) const;
  bool hit(const Ray& ray, LightHit* out) const;
};

// Any emitter, with uniform dispatch.
using Emitter = std::variant<PointLight, SunLight, AreaLight>;

bool is_delta(const Emitter& e);
LightSample sample_li(const Emitter& e, Vec3 p, float u0, float u1);
float light_pdf(const Emitter& e, Vec3 p, Vec3 wi);
bool light_hit(const Emitter& e, const Ray& ray, LightHit* out);

}  // namespace ptir
