// Blender light units -> radiometric quantities, exactly as Cycles (Blender 3.4)
// converts them. Blender's `energy` is "Watts" but Cycles does not treat it as the
// emitted radiant flux for every light type; these are Cycles' own factors, read
// from its source and verified against Cycles renders by
// tests/python/test_light_units.py (tests/blender/light_units_reference.py), which
// uses the same formulas in Python. Every quantity is per colour channel and gets
// multiplied by the light's colour (Cycles: strength = colour * energy).
//
// Cycles 3.4 source (intern/cycles): blender/light.cpp sets strength = colour *
// energy for every type; scene/light.cpp and kernel/light/{point,area,distant}.h:
//
// Point light, radius r = 0 (delta):  eval_fac = 1/(4 pi), pdf = t^2
//   -> radiant intensity  I = P / (4 pi)  [W/sr]           (isotropic; emits P in total)
// Point light, radius r > 0: a disc of radius r centred on the light, facing the
//   shading point, uniformly sampled (invarea = 1/(pi r^2)), eval_fac = invarea/(4 pi)
//   -> radiance  L = P / (4 pi * pi r^2)  [W/(m^2 sr)]  (on axis: E = pi L r^2/(d^2 + r^2))
// Area light (one-sided, emits along the object's local -z), eval_fac = invarea / 4
//   -> radiance  L = P / (4 A)  [W/(m^2 sr)], A = size_x * size_y (square / rectangle)
//      or A = pi/4 * size_x * size_y (disk / ellipse; size = diameter), sizes times
//      the object's scale. NOTE: a Lambertian emitter of radiance L emits pi L A,
//      so a Cycles area light of "P W" actually emits (pi/4) P W. (Assumes Blender's
//      default Spread of 180 degrees; a narrower spread is not modelled.)
// Sun light, angle 0 (delta): strength s is the irradiance on a surface facing the
//   sun  E = s [W/m^2]  (E = s cos(theta) at incidence theta).
// Sun light, angle a > 0: directions within a/2 of the sun axis, sampled as a disc
//   of radius tan(a/2) at unit distance; eval_fac = pdf = invarea / cos^3(theta),
//   invarea = 1/(pi tan^2(a/2))
//   -> radiance  L(theta) = s / (pi tan^2(a/2) cos^3(theta)), theta from the axis;
//      irradiance facing the sun E = s * 2 (1/cos(a/2) - 1) / tan^2(a/2)  (-> s as a -> 0).
// World: radiance = Background strength * colour (* texel of an Environment Texture);
//   a uniform world of radiance L gives E = pi L on an unoccluded surface.
//
// Measured (Cycles 3.4.1, albedo 0.8 Diffuse plane, L_o = 0.8/pi E; ours vs Cycles):
//   point 100 W h 2: 0.50661 vs 0.50653; point 100 W r 0.5 h 1: 1.62114 vs 1.62029;
//   square 1 m 50 W h 2: 0.73478 vs 0.73470; rect 2x0.5 m 80 W h 1.5: 1.75265 vs 1.75225;
//   disk 1 m 50 W h 2: 0.74896 vs 0.74881; sun 3: 0.763944 vs 0.763944; sun 3 at 40 deg:
//   0.585215 vs 0.585215; sun 3 angle 60 deg: 0.70910 vs 0.70911; world 1.5: 1.2 vs 1.2.
// Blender 4.x reworked point/spot lights (spheres) and may differ: rerun the pytest
// with that Blender before relying on these for it.
#pragma once

#include <cmath>

#include "ptir/math/vec.h"

namespace ptir::blender_units {

// I = kPointIntensityPerWatt * P.
constexpr double kPointIntensityPerWatt = 0.07957747154594767;  // 1 / (4 pi)
// L = kAreaRadiancePerWatt * P / A.
constexpr double kAreaRadiancePerWatt = 0.25;

// Point light (radius 0): radiant intensity in W/sr.
inline float point_intensity(float watts) { return float(kPointIntensityPerWatt * watts); }
// Point light with radius > 0: radiance of the disc that faces the shading point.
inline float point_radiance(float watts, float radius) {
  return float(kPointIntensityPerWatt * watts / (3.14159265358979323846 * double(radius) * radius));
}

// Area of a Blender area light (sizes already multiplied by the object's scale).
inline float rect_area(float size_x, float size_y) { return size_x * size_y; }
inline float ellipse_area(float diameter_x, float diameter_y) {
  return float(0.78539816339744831 * diameter_x * diameter_y);  // pi / 4
}
// Area light radiance in W/(m^2 sr).
inline float area_radiance(float watts, float area) { return float(kAreaRadiancePerWatt * watts / area); }

// Sun (angle 0): irradiance on a surface facing the sun, W/m^2.
inline float sun_irradiance(float strength) { return strength; }
// Sun with angle a > 0: 1 / (pi tan^2(a/2)) (Cycles' invarea).
inline float sun_invarea(float angle) {
  double t = std::tan(0.5 * double(angle));
  return float(1.0 / (3.14159265358979323846 * t * t));
}
// Sun with angle a > 0: radiance at cos_theta from the sun axis (inside the cone).
inline float sun_radiance(float strength, float angle, float cos_theta) {
  return float(double(strength) * sun_invarea(angle) / (double(cos_theta) * cos_theta * cos_theta));
}
// Sun with angle a > 0: irradiance on a surface facing the sun.
inline float sun_irradiance_with_angle(float strength, float angle) {
  if (!(angle > 0.0f)) return strength;
  double h = 0.5 * double(angle), t = std::tan(h);
  return float(double(strength) * 2.0 * (1.0 / std::cos(h) - 1.0) / (t * t));
}

// World: radiance scale of the Background node.
inline float world_radiance(float strength, float colour = 1.0f) { return strength * colour; }

// RGB helpers (colour * energy, as Cycles does).
inline Vec3 point_intensity(float watts, Vec3 colour) { return colour * point_intensity(watts); }
inline Vec3 area_radiance(float watts, float area, Vec3 colour) { return colour * area_radiance(watts, area); }

}  // namespace ptir::blender_units
