"""Pixels of the engine's EXR output, read through Blender's image loader (the raw passes: io/raw_pixels.py)."""

import bpy
import numpy as np

from ..errors import ExportError


def read_exr_pixels(path, width, height):
    """(height * width, 4) float32 RGBA rows bottom-up (Blender's order) of a linear EXR, via Blender."""
    img = bpy.data.images.load(path, check_existing=False)
    try:
        if tuple(img.size) != (width, height):
            raise ExportError("the engine wrote a %dx%d image, expected %dx%d"
                              % (img.size[0], img.size[1], width, height))
        px = np.empty(width * height * 4, np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    return px.reshape(-1, 4)
