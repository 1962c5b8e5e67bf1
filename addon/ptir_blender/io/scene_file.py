"""The scene-file schema (docs/scene_format.md) on the Python side, without bpy.

Small pure functions shared by the Blender exporter, the tests and scripts:
matrices as JSON rows, Blender's camera field of view and render size rules,
and writing the file.
"""

import json
import math
import os
from ..errors import SceneFileError
from .atomic_file import write_atomic

FORMAT_VERSION = 1
TOP_LEVEL_KEYS = ("version", "comment", "brdf", "gaussians", "meshes", "lights", "environment", "cameras",
                  "integrator")
# The surface models a scene's "brdf" names ("principled": v1, its name before v2 existed).
BRDF_MODELS = ("principled", "principled-v1", "principled-v2", "disney-simplified")
INTEGRATOR_KEYS = ("spp", "bounces", "seed", "interaction", "tau_g", "geometric_criterion", "self_intersection",
                   "self_range_scale", "fixed_offset", "fixed_range", "min_throughput", "pixel_filter", "filter_width",
                   "light_selection", "russian_roulette", "min_light_bounces")


def matrix_rows(m):
    """A 4x4 matrix (nested sequences, numpy array or mathutils.Matrix) -> 4 lists of 4 floats (row-major)."""
    rows = [[float(m[r][c]) for c in range(4)] for r in range(4)]
    for row in rows:
        for v in row:
            if not math.isfinite(v):
                raise SceneFileError("matrix has a non-finite entry: %r" % (rows,))
    return rows


def render_size(resolution_x, resolution_y, percentage=100):
    """Blender's output size: resolution times percentage / 100, rounded down (at least 1)."""
    return max(1, int(resolution_x) * int(percentage) // 100), max(1, int(resolution_y) * int(percentage) // 100)


def horizontal_fov(lens, sensor_width, sensor_height, sensor_fit, width, height, pixel_aspect_x=1.0,
                   pixel_aspect_y=1.0):
    """Horizontal field of view (radians) of a Blender perspective camera.

    Blender (BKE_camera_params_compute_viewplane): the sensor size used is
    sensor_width for AUTO and HORIZONTAL fit, sensor_height for VERTICAL; with AUTO
    it spans the larger image dimension (in pixel-aspect-corrected units), with
    HORIZONTAL the width, with VERTICAL the height.
    """
    if lens <= 0:
        raise SceneFileError("camera focal length must be positive, got %r" % lens)
    aspect = (float(width) * pixel_aspect_x) / (float(height) * pixel_aspect_y)
    if sensor_fit == "VERTICAL":
        fit_horizontal = False
        sensor = sensor_height
    elif sensor_fit == "HORIZONTAL":
        fit_horizontal = True
        sensor = sensor_width
    elif sensor_fit == "AUTO":
        fit_horizontal = aspect >= 1.0
        sensor = sensor_width
    else:
        raise SceneFileError("unknown sensor fit %r" % sensor_fit)
    half = 0.5 * sensor / lens  # tan of the half angle along the fitted dimension
    if fit_horizontal:
        return 2.0 * math.atan(half)
    return 2.0 * math.atan(half * aspect)


def validate_top_level(scene):
    unknown = sorted(set(scene) - set(TOP_LEVEL_KEYS))
    if unknown:
        raise SceneFileError("unknown scene keys %s (expected %s)" % (unknown, ", ".join(TOP_LEVEL_KEYS)))
    if "brdf" in scene and scene["brdf"] not in BRDF_MODELS:
        raise SceneFileError("unknown brdf %r (expected %s)" % (scene["brdf"], ", ".join(BRDF_MODELS)))
    integ = scene.get("integrator") or {}
    unknown = sorted(set(integ) - set(INTEGRATOR_KEYS))
    if unknown:
        raise SceneFileError("unknown integrator keys %s (expected %s)" % (unknown, ", ".join(INTEGRATOR_KEYS)))


def dumps(obj, indent=1):
    """JSON with one key per line but lists of numbers (vectors, matrix rows) kept on one line."""
    def fmt(o, level):
        pad = " " * (indent * level)
        inner = " " * (indent * (level + 1))
        if isinstance(o, dict):
            if not o:
                return "{}"
            items = ["%s%s: %s" % (inner, json.dumps(str(k)), fmt(v, level + 1)) for k, v in o.items()]
            return "{\n" + ",\n".join(items) + "\n" + pad + "}"
        if isinstance(o, (list, tuple)):
            if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in o):
                return "[" + ", ".join(json.dumps(v) for v in o) + "]"
            if all(isinstance(v, (list, tuple)) and all(isinstance(x, (int, float)) for x in v) for v in o) and o:
                return "[" + ", ".join(fmt(v, level + 1) for v in o) + "]"
            if not o:
                return "[]"
            return "[\n" + ",\n".join(inner + fmt(v, level + 1) for v in o) + "\n" + pad + "]"
        return json.dumps(o)
    return fmt(obj, 0)


def write_scene(path, scene):
    """Writes the scene dict as JSON (top-level keys checked), atomically; returns the path."""
    validate_top_level(scene)
    out = dict(scene)
    out.setdefault("version", FORMAT_VERSION)
    return write_atomic(path, ((dumps(out) + "\n").encode("utf-8"),), SceneFileError)


def relative_path(path, base_dir):
    """path relative to base_dir when it lies under it (portable scene folders), else absolute."""
    path = os.path.abspath(path)
    base = os.path.abspath(base_dir)
    try:
        rel = os.path.relpath(path, base)
    except ValueError:
        return path
    return path if rel.startswith("..") else rel
