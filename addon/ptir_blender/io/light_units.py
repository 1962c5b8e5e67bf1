"""Blender light settings -> the scene file's light units, per Blender version (no bpy).

The scene file's units are those of Cycles in Blender 3.x (native/src/ptir/lights/light_units.h;
docs/scene_format.md). Blender 4.0 changed two of them; measured with Cycles itself
(tests/blender/light_units_reference.py; albedo-0.8 Diffuse plane, ratios 4.5 / 3.4 and 5.0 / 3.4):
  - area lights (square, rectangle, disk, ellipse) emit their Power as a Lambertian emitter
    (radiance P / (pi A)); 3.x gave P / (4 A): 4/pi brighter for the same Power (measured
    1.2731-1.2734, 4/pi = 1.2732)
  - a sun with an angle gives its Strength as the irradiance facing it; 3.x gave
    s * 2 (1/cos(a/2) - 1) / tan^2(a/2) (60 degrees: 0.928 s; measured ratio 1.0773-1.0774)
Point lights (with or without radius), sharp suns and the world are unchanged (measured within 0.02 %).
"""

import math

AREA_POWER_4X = 4.0 / math.pi


def area_power(power, version):
    """The scene file's power of a Blender area light of `power` W in Blender `version` (major, minor, ...)."""
    return float(power) * (AREA_POWER_4X if tuple(version) >= (4, 0, 0) else 1.0)


def sun_strength(strength, angle, version):
    """The scene file's strength of a Blender sun of `strength` and angular diameter `angle` (radians)."""
    if tuple(version) < (4, 0, 0) or not angle > 1e-6:
        return float(strength)
    h = 0.5 * float(angle)
    t = math.tan(h)
    return float(strength) * t * t / (2.0 * (1.0 / math.cos(h) - 1.0))
