"""A Blender image's float pixels as a linear image file the engine reads (texture and world export)."""

import os

import numpy as np

from ..io import native_module
from ..io.hdr_file import write_rgbe


def save_image_exr(image, path):
    """Writes a Blender image's float pixels to a linear EXR through the native module when
    available, else as a Radiance .hdr written with numpy (Image.save would display-encode)."""
    w, h = image.size
    px = np.empty(w * h * image.channels, np.float32)
    image.pixels.foreach_get(px)
    px = px.reshape(h, w, image.channels)[::-1, :, :3]  # Blender stores rows bottom-up
    root = os.path.splitext(path)[0]
    try:
        ptir = native_module.native()
        ptir.write_image(root + ".exr", np.ascontiguousarray(px))
        return root + ".exr"
    except Exception:
        return write_rgbe(root + ".hdr", px)
