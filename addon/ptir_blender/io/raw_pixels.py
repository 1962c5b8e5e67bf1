"""The engine's raw AOV images (float32, top row first, as `ptir serve` writes them) as Blender render passes."""

import numpy as np

# AOV render passes: (Blender pass name, engine AOV, channels, channel ids, socket type, engine channels used).
AOV_PASSES = (("Depth", "depth", 1, "Z", "VALUE", (0,)),
              ("Normal", "normal", 3, "XYZ", "VECTOR", (0, 1, 2)),
              ("Albedo", "albedo", 3, "RGB", "COLOR", (0, 1, 2)),
              ("Roughness", "roughness", 1, "X", "VALUE", (0,)),
              ("Metallic", "metallic", 1, "X", "VALUE", (0,)),
              ("Opacity", "opacity", 1, "X", "VALUE", (0,)))


def read_raw_pass(path, width, height, channels_used):
    """Rows bottom-up (Blender's order) of the chosen channels of a raw engine image."""
    px = np.fromfile(path, np.float32)
    c = px.size // (width * height)
    px = px.reshape(height, width, c)[::-1][..., list(channels_used)]
    return np.ascontiguousarray(px.reshape(-1, len(channels_used)))
