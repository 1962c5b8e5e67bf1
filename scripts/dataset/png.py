"""8-bit PNG writing and sRGB encoding in pure Python + numpy (no Blender colour management)."""

import struct
import zlib

import numpy as np


def srgb_encode(linear):
    """IEC 61966-2-1 sRGB encoding of linear values (clamped to [0, 1] first)."""
    c = np.clip(np.asarray(linear, np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)


def srgb_decode(encoded):
    c = np.clip(np.asarray(encoded, np.float64), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, np.power((c + 0.055) / 1.055, 2.4))


def to_8bit(values):
    """[0, 1] floats -> uint8 with round-to-nearest."""
    return np.clip(np.rint(np.asarray(values, np.float64) * 255.0), 0, 255).astype(np.uint8)


def _chunk(kind, data):
    body = kind + data
    return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)


def write_png(path, pixels):
    """Writes an (H, W) or (H, W, C) uint8 array (C = 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA)."""
    a = np.asarray(pixels)
    if a.dtype != np.uint8:
        raise ValueError("write_png needs uint8 pixels")
    if a.ndim == 2:
        a = a[:, :, None]
    h, w, c = a.shape
    colour_type = {1: 0, 2: 4, 3: 2, 4: 6}[c]
    raw = np.concatenate([np.zeros((h, 1), np.uint8), a.reshape(h, w * c)], axis=1).tobytes()
    data = b"\x89PNG\r\n\x1a\n"
    data += _chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0))
    data += _chunk(b"IDAT", zlib.compress(raw, 6))
    data += _chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(data)
