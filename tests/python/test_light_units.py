"""Blender light units and environment orientation, checked against Cycles.

Runs tests/blender/light_units_reference.py in Blender (Cycles, CPU, a few
seconds in all) and compares what Cycles rendered with closed forms computed from
OUR conversions -- the formulas and constants below are those of
native/src/ptir/lights/light_units.h (tests/native/test_lights.cpp pins the C++
side to the same REFERENCE numbers) -- and with our lat-long lookup (the formulas
of native/src/ptir/lights/environment.h; tests/native/test_environment.cpp checks
the C++ lookup against the same Cycles colours).

Scenes (direct light only, albedo-0.8 Diffuse BSDF plane at z = 0, orthographic
camera looking straight down, so each pixel shows L_o = albedo / pi * E):
  point P=100 W at h=2 (radius 0), point 100 W radius 0.5 at h=1, square area
  light 1 m 50 W at h=2, rectangle 2 x 0.5 m 80 W at h=1.5, disk 1 m 50 W at h=2,
  sun strength 3 (vertical; tilted 40 degrees; angle 60 degrees), uniform world
  of strength 1.5.

Tolerance: 0.5 % (or 6 standard errors of the image mean, if larger). Cycles is
noise-free for the delta lights and the uniform world (each sample gives the
exact value) and the area lights' image mean at 64 spp x 256 pixels has a
standard error ~ 1e-4 relative; the camera footprint (5 cm) changes the
irradiance by < 0.1 %. 0.5 % is therefore loose for noise yet 30x tighter than
the smallest unit mistake we could make (pi/4 on area lights, 1/pi on points).
"""

import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "tests" / "blender" / "light_units_reference.py"
sys.path.insert(0, str(REPO / "tests" / "blender"))
sys.path.insert(0, str(REPO / "addon"))
import blenders  # noqa: E402  (the three Blenders: 3.4, bpy 4.5, bpy 5.0)
from ptir_blender.io import light_units as blender_units  # noqa: E402  (the add-on's per-version conversion)

# ---- our conversions: identical to native/src/ptir/lights/light_units.h --------------

POINT_INTENSITY_PER_WATT = 1.0 / (4.0 * math.pi)  # I = P / (4 pi)      [W/sr]
AREA_RADIANCE_PER_WATT = 0.25                     # L = P / (4 A)       [W/(m^2 sr)]


def point_intensity(watts):
    return POINT_INTENSITY_PER_WATT * watts


def point_radiance(watts, radius):
    """Radius > 0: a disc of that radius facing the shading point."""
    return POINT_INTENSITY_PER_WATT * watts / (math.pi * radius * radius)


def rect_area(size_x, size_y):
    return size_x * size_y


def ellipse_area(diameter_x, diameter_y):
    return math.pi / 4.0 * diameter_x * diameter_y


def area_radiance(watts, area):
    return AREA_RADIANCE_PER_WATT * watts / area


def sun_irradiance(strength):
    return strength


def sun_invarea(angle):
    return 1.0 / (math.pi * math.tan(0.5 * angle) ** 2)


def sun_radiance(strength, angle, cos_theta):
    return strength * sun_invarea(angle) / cos_theta ** 3


def sun_irradiance_with_angle(strength, angle):
    h = 0.5 * angle
    return strength * 2.0 * (1.0 / math.cos(h) - 1.0) / math.tan(h) ** 2


def world_radiance(strength, colour=1.0):
    return strength * colour


# The same numbers are asserted in tests/native/test_lights.cpp (LightUnits.MatchTheReferenceTable).
REFERENCE = {
    "point_intensity(100)": 7.957747154594767,
    "point_radiance(100, 0.5)": 10.132118364233778,
    "area_radiance(50, rect_area(1, 1))": 12.5,
    "area_radiance(80, rect_area(2, 0.5))": 20.0,
    "ellipse_area(1, 1)": 0.7853981633974483,
    "area_radiance(50, ellipse_area(1, 1))": 15.915494309189533,
    "sun_irradiance(3)": 3.0,
    "sun_irradiance_with_angle(3, pi/3)": 2.784609690826527,
    "sun_invarea(pi/3)": 0.954929658551372,
    "world_radiance(1.5)": 1.5,
}


def reference_values():
    return {
        "point_intensity(100)": point_intensity(100.0),
        "point_radiance(100, 0.5)": point_radiance(100.0, 0.5),
        "area_radiance(50, rect_area(1, 1))": area_radiance(50.0, rect_area(1.0, 1.0)),
        "area_radiance(80, rect_area(2, 0.5))": area_radiance(80.0, rect_area(2.0, 0.5)),
        "ellipse_area(1, 1)": ellipse_area(1.0, 1.0),
        "area_radiance(50, ellipse_area(1, 1))": area_radiance(50.0, ellipse_area(1.0, 1.0)),
        "sun_irradiance(3)": sun_irradiance(3.0),
        "sun_irradiance_with_angle(3, pi/3)": sun_irradiance_with_angle(3.0, math.pi / 3),
        "sun_invarea(pi/3)": sun_invarea(math.pi / 3),
        "world_radiance(1.5)": world_radiance(1.5),
    }


# ---- irradiance on the plane point below the light, by quadrature -------------------

def irradiance_rect(L, size_x, size_y, h, n=400):
    """E = L * integral of cos cos / r^2 over a parallel rectangle centred above."""
    acc = 0.0
    dx, dy = size_x / n, size_y / n
    for i in range(n):
        x = -0.5 * size_x + (i + 0.5) * dx
        for j in range(n):
            y = -0.5 * size_y + (j + 0.5) * dy
            r2 = x * x + y * y + h * h
            acc += h * h / (r2 * r2)
    return L * acc * dx * dy


def irradiance_disc(L, radius, h, n=20000):
    """Parallel disc centred above (polar midpoint rule)."""
    acc = 0.0
    dr = radius / n
    for i in range(n):
        r = (i + 0.5) * dr
        acc += 2.0 * math.pi * r * h * h / (r * r + h * h) ** 2
    return L * acc * dr


def irradiance_sun_cone(strength, angle, n=20000):
    """Vertical sun with an angular diameter: integral of L(theta) cos(theta) d omega."""
    half = 0.5 * angle
    acc = 0.0
    dt = half / n
    for i in range(n):
        t = (i + 0.5) * dt
        acc += sun_radiance(strength, angle, math.cos(t)) * math.cos(t) * 2.0 * math.pi * math.sin(t)
    return acc * dt


def expected_irradiance(name, p):
    if name == "point":
        return point_intensity(p["power"]) / p["height"] ** 2
    if name == "point_radius":
        return irradiance_disc(point_radiance(p["power"], p["radius"]), p["radius"], p["height"])
    if name in ("area_square", "area_rect"):
        L = area_radiance(p["power"], rect_area(p["size_x"], p["size_y"]))
        return irradiance_rect(L, p["size_x"], p["size_y"], p["height"])
    if name == "area_disk":
        d = p["diameter"]
        return irradiance_disc(area_radiance(p["power"], ellipse_area(d, d)), 0.5 * d, p["height"])
    if name in ("sun", "sun_tilted"):
        return sun_irradiance(p["strength"]) * math.cos(p["zenith"])
    if name == "sun_angle":
        return irradiance_sun_cone(p["strength"], p["angle"])
    if name == "world":
        return math.pi * world_radiance(p["strength"], p["colour"])
    raise KeyError(name)


# ---- our lat-long lookup: identical to native/src/ptir/lights/environment.h ----------

def env_lookup_texel(d, rotation_z, width, height):
    """(col, row, u_frac_margin, t_frac_margin) of the texel a world direction looks up."""
    c, s = math.cos(rotation_z), math.sin(rotation_z)
    x, y, z = c * d[0] - s * d[1], s * d[0] + c * d[1], d[2]
    u = 0.5 - math.atan2(y, x) / (2.0 * math.pi)
    u -= math.floor(u)
    t = math.atan2(math.hypot(x, y), z) / math.pi  # = 1 - v, v = 0.5 + asin(z)/pi
    fu, ft = u * width, t * height
    col = int(math.floor(fu)) % width
    row = min(int(math.floor(ft)), height - 1)  # row 0 = top of the file = +z
    margin = min(fu - math.floor(fu), math.ceil(fu) - fu, ft - math.floor(ft), math.ceil(ft) - ft)
    return col, row, margin


def coded_texel(col, row, width, height):
    """The texel-coded map of light_units_reference.py."""
    return ((col + 0.5) / width, (row + 0.5) / height, 0.25)


# ---- the Cycles run --------------------------------------------------------------

@pytest.fixture(scope="module", params=blenders.params())
def cycles(request):
    with tempfile.TemporaryDirectory(prefix="ptir_light_units_") as tmp:
        cmd = blenders.command(request.param, SCRIPT, ["--out-dir", tmp, "--samples", "64"])
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        out = proc.stdout + proc.stderr
        assert proc.returncode == 0, "Blender failed:\n" + out[-4000:]
        lines = [l for l in proc.stdout.splitlines() if l.startswith("PTIR_LIGHT_UNITS_JSON: ")]
        assert lines, "no result line from Blender:\n" + out[-4000:]
        return json.loads(lines[-1].split(": ", 1)[1])


def test_reference_table_matches_formulas():
    values = reference_values()
    for key, ref in REFERENCE.items():
        assert values[key] == pytest.approx(ref, rel=1e-12), key


LAMBERT_CASES = ["point", "point_radius", "area_square", "area_rect", "area_disk", "sun",
                 "sun_tilted", "sun_angle", "world"]


@pytest.mark.parametrize("name", LAMBERT_CASES)
def test_cycles_matches_our_units(cycles, name):
    """Each Blender's Cycles against our units, after the add-on's conversion of that Blender's light
    settings (io/light_units.py: 4.0+ area power x 4/pi, angled suns' strength)."""
    case = cycles["lambert"][name]
    albedo = cycles["albedo"]
    params, version = dict(case["params"]), cycles["blender_version"]
    if "power" in params and name.startswith("area"):
        params["power"] = blender_units.area_power(params["power"], version)
    if "strength" in params and name.startswith("sun"):
        params["strength"] = blender_units.sun_strength(params["strength"], params.get("angle", 0.0), version)
    expected = albedo / math.pi * expected_irradiance(name, params)
    measured = case["rgb"]
    tol = max(5e-3 * expected, 6.0 * case["sem"])
    for c in range(3):
        assert measured[c] == pytest.approx(expected, abs=tol), (
            "%s: Cycles %.6f vs ours %.6f (params %s)" % (name, measured[c], expected, case["params"]))


def test_closed_forms_agree_with_quadrature():
    # Sanity of the quadrature: closed forms for the on-axis disc and rectangle.
    L, R, h = 3.0, 0.5, 2.0
    assert irradiance_disc(L, R, h) == pytest.approx(math.pi * L * R * R / (h * h + R * R), rel=1e-6)
    X, Y = 2.0 / (2 * 1.5), 0.5 / (2 * 1.5)  # half-sizes over the height
    sx, sy = math.sqrt(1 + X * X), math.sqrt(1 + Y * Y)
    closed = 2 * 20.0 * (X / sx * math.atan(Y / sx) + Y / sy * math.atan(X / sy))
    assert irradiance_rect(20.0, 2.0, 0.5, 1.5) == pytest.approx(closed, rel=1e-4)
    assert irradiance_sun_cone(3.0, math.pi / 3) == pytest.approx(
        sun_irradiance_with_angle(3.0, math.pi / 3), rel=1e-6)


def test_cycles_environment_orientation_matches_our_lookup(cycles):
    width, height = cycles["env_size"]
    assert len(cycles["env"]) >= 24
    rotations = set()
    for e in cycles["env"]:
        col, row, margin = env_lookup_texel(e["direction"], e["rotation_z"], width, height)
        # Test design guard: each direction must sit well inside one texel.
        assert margin > 0.03, e
        expected = [e["strength"] * v for v in coded_texel(col, row, width, height)]
        rotations.add(e["rotation_z"])
        for c in range(3):
            assert e["rgb"][c] == pytest.approx(expected[c], abs=1e-4), (
                "direction %s rotation %s: Cycles %s, ours texel (%d, %d) = %s"
                % (e["direction"], e["rotation_z"], e["rgb"], col, row, expected))
    assert len(rotations) >= 3  # 0 and both signs


def test_cycles_environment_rotation_sign(cycles):
    # With the opposite rotation sign our lookup would disagree with Cycles.
    width, height = cycles["env_size"]
    wrong = 0
    for e in cycles["env"]:
        if e["rotation_z"] == 0.0:
            continue
        col, row, _ = env_lookup_texel(e["direction"], -e["rotation_z"], width, height)
        expected = [e["strength"] * v for v in coded_texel(col, row, width, height)]
        if any(abs(e["rgb"][c] - expected[c]) > 1e-4 for c in range(3)):
            wrong += 1
    assert wrong > 0
