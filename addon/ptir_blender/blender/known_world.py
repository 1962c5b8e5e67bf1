"""The World's light as a known environment for `ptir optimize` (issue 52: Optimise > Light).

Light: Known (the World) / Known + Refine write the World's Background -- its Environment
Texture (or plain colour), Strength and Mapping Z rotation, as scene_export.world_entry reads
them -- as one lat-long map in Blender orientation with the strength and rotation baked in.
`ptir optimize --env-init MAP` lines it up with the photos (--env-align auto: its yaw; a World
that already matches them stays at 0 degrees) and keeps it fixed (--fix-env) or learns it
gently (--env-refine). Learn (the default) leaves the World out, as before.
"""

import math
import os

import bpy
import numpy as np

from ..errors import OptimizeError
from ..io import native_module
from ..io.hdr_file import write_rgbe
from . import scene_export

LIGHT_FLAGS = {"KNOWN": ["--fix-env"], "KNOWN_REFINE": ["--env-refine"]}
COLOUR_SIZE = (64, 32)  # a plain-colour World's map (width, height)


def rotate_yaw(rgb, rotation_z):
    """The lat-long map (h, w, 3) with the Mapping node's Z rotation baked in: looked up without a
    rotation it gives what `rgb` gives with it (lights/environment.h: a direction at u reads the map
    at u - rotation_z / 2 pi), by linear interpolation along each row."""
    w = rgb.shape[1]
    shift = (-rotation_z / (2.0 * math.pi) * w) % w
    whole = int(math.floor(shift))
    frac = shift - whole
    a = np.roll(rgb, -whole, axis=1)
    return a if frac == 0.0 else (1.0 - frac) * a + frac * np.roll(a, -1, axis=1)


def _read_map(path):
    try:
        return np.asarray(native_module.native().read_image(path), np.float32)[:, :, :3]
    except ImportError:  # (no native module: Blender reads it; its rows are bottom-up)
        image = bpy.data.images.load(path, check_existing=True)
        w, h = image.size
        px = np.empty(w * h * image.channels, np.float32)
        image.pixels.foreach_get(px)
        return px.reshape(h, w, image.channels)[::-1, :, :3]


def _write_map(path, rgb):
    rgb = np.ascontiguousarray(rgb, np.float32)
    try:
        native_module.native().write_image(path, rgb)
        return path
    except ImportError:
        return write_rgbe(os.path.splitext(path)[0] + ".hdr", rgb)


def write_known_world(scene, out_dir, warnings):
    """Writes the World's light into out_dir and returns the map's path (OptimizeError without one)."""
    entry = scene_export.world_entry(scene.world, out_dir, warnings)
    if entry is None:
        raise OptimizeError("Light: Known needs the World's light: give the World a Background "
                            "(an Environment Texture or a colour)")
    if entry["type"] == "color":
        rgb = np.empty((COLOUR_SIZE[1], COLOUR_SIZE[0], 3), np.float32)
        rgb[:] = np.asarray(entry["color"], np.float32)
    else:
        rgb = rotate_yaw(_read_map(os.path.normpath(os.path.join(out_dir, entry["file"]))), entry["rotation_z"])
    return _write_map(os.path.join(out_dir, "known_world.exr"), rgb * np.float32(entry["strength"]))


def light_args(settings, known_map):
    """`ptir optimize`'s arguments for the Light setting (none for Learn)."""
    if getattr(settings, "light", "LEARN") not in LIGHT_FLAGS or not known_map:
        return []
    return ["--env-init", known_map] + LIGHT_FLAGS[settings.light]
