"""Radiance .hdr (RGBE) files from float pixels, with numpy alone."""

import numpy as np


def write_rgbe(path, rgb):
    """Flat (uncompressed) Radiance .hdr from float (h, w, 3), numpy only; row 0 = top."""
    rgb = np.maximum(np.asarray(rgb, np.float64), 0.0)
    h, w, _ = rgb.shape
    v = rgb.max(axis=2)
    m, e = np.frexp(v)
    scale = np.where(v > 1e-32, m * 256.0 / np.maximum(v, 1e-32), 0.0)
    out = np.zeros((h, w, 4), np.uint8)
    out[..., :3] = np.clip(rgb * scale[..., None], 0, 255).astype(np.uint8)
    out[..., 3] = np.where(v > 1e-32, e + 128, 0).astype(np.uint8)
    with open(path, "wb") as f:
        f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n")
        f.write(("-Y %d +X %d\n" % (h, w)).encode("ascii"))
        f.write(out.tobytes())
    return path
