"""SuperSplat / PlayCanvas compressed splat PLY -> the standard 3DGS layout's raw columns.

The compressed layout: an element 'chunk' (one row per 256 splats) holds each chunk's
bounds (min_x..max_z, min_scale_x..max_scale_z, optionally min_r..max_b), and the
'vertex' element holds four uint32 words per splat:
    packed_position  x, y, z as 11/10/11-bit fractions of the chunk's position bounds
    packed_scale     log scales, 11/10/11 bits within the chunk's scale bounds
    packed_color     r, g, b (8 bits each, within the colour bounds when present), opacity (8 bits)
    packed_rotation  "smallest three": 2 bits for the largest component's index, the other
                     three in 10 bits each ((u - 0.5) * sqrt(2))
and an optional element 'sh' has uchar f_rest_* (8 ((b + 0.5) / 256 - 0.5); 0 and 255 map
to -4 and 4). Decoded exactly as the engine decodes it
(native/src/ptir/scene/gaussian_ply.cpp), in numpy, into raw (file) values that
splat_ply.read_splat_ply then activates as for any other file.
"""

import math

import numpy as np

from ..errors import SplatPlyError
from .sh_basis import dc_of_colour


def is_compressed(elements):
    """Whether the elements read by splat_ply.read_ply_elements are a compressed splat PLY."""
    return "chunk" in elements and any(k.startswith("packed_") for k in elements.get("vertex", {}))


def _unorm(bits, width):
    return (bits & np.uint32((1 << width) - 1)).astype(np.float64) / float((1 << width) - 1)


def decode_compressed(els, path):
    """SuperSplat compressed PLY -> {property: raw float32 column} in the standard layout."""
    chunk, vertex = els["chunk"], els["vertex"]
    n = len(next(iter(vertex.values()))) if vertex else 0
    words = {}
    for name in ("packed_position", "packed_rotation", "packed_scale", "packed_color"):
        col = vertex.get(name)
        if col is None:
            raise SplatPlyError("%s: compressed splat PLY: vertex property '%s' is missing" % (path, name))
        if col.dtype.kind not in "ui" or col.dtype.itemsize != 4:
            raise SplatPlyError("%s: compressed splat PLY: vertex property '%s' must be a 32-bit unsigned integer"
                                % (path, name))
        words[name] = col.astype(np.uint32, copy=False)
    nchunks = len(next(iter(chunk.values()))) if chunk else 0
    need = (n + 255) // 256
    if nchunks < need:
        raise SplatPlyError("%s: compressed splat PLY: %d splats need %d chunks of 256, the file has %d"
                            % (path, n, need, nchunks))
    ci = np.arange(n) // 256

    def bound(name):
        if name not in chunk:
            raise SplatPlyError("%s: compressed splat PLY: chunk property '%s' is missing or not a scalar"
                                % (path, name))
        return chunk[name].astype(np.float64)[ci]

    colour_names = ["min_r", "min_g", "min_b", "max_r", "max_g", "max_b"]
    have = sum(c in chunk for c in colour_names)
    if have not in (0, 6):
        raise SplatPlyError("%s: compressed splat PLY: chunk has only some of the colour bounds min_r..max_b" % path)
    out = {}
    widths, shifts = (11, 10, 11), (21, 11, 0)
    pw, sw, cw = words["packed_position"], words["packed_scale"], words["packed_color"]
    for k, axis in enumerate("xyz"):
        t = _unorm(pw >> np.uint32(shifts[k]), widths[k])
        lo, hi = bound("min_" + axis), bound("max_" + axis)
        out[axis] = (lo * (1.0 - t) + hi * t).astype(np.float32)
    for k, axis in enumerate("xyz"):
        t = _unorm(sw >> np.uint32(shifts[k]), widths[k])
        lo, hi = bound("min_scale_" + axis), bound("max_scale_" + axis)
        out["scale_%d" % k] = (lo * (1.0 - t) + hi * t).astype(np.float32)
    for k, c in enumerate("rgb"):
        t = _unorm(cw >> np.uint32(24 - 8 * k), 8)
        if have:
            lo, hi = bound("min_" + c), bound("max_" + c)
            t = lo * (1.0 - t) + hi * t
        out["f_dc_%d" % k] = dc_of_colour(t).astype(np.float32)
    a = np.clip(_unorm(cw, 8), 1e-6, 1.0 - 1e-6)
    out["opacity"] = np.log(a / (1.0 - a)).astype(np.float32)
    rw = words["packed_rotation"]
    s = math.sqrt(2.0)
    abc = [(_unorm(rw >> np.uint32(sh), 10) - 0.5) * s for sh in (20, 10, 0)]
    m = np.sqrt(np.maximum(0.0, 1.0 - (abc[0] ** 2 + abc[1] ** 2 + abc[2] ** 2)))
    largest = (rw >> np.uint32(30)).astype(np.int64)
    q = np.empty((n, 4), np.float64)
    for k in range(4):
        # component k: m when it is the largest, else the j-th of the three stored ones
        j = np.where(largest > k, k, k - 1)
        stored = np.choose(np.clip(j, 0, 2), abc)
        q[:, k] = np.where(largest == k, m, stored)
    for k in range(4):
        out["rot_%d" % k] = q[:, k].astype(np.float32)
    sh = els.get("sh")
    if sh is not None:
        count = len(sh)
        if count not in (9, 24, 45):
            raise SplatPlyError("%s: compressed splat PLY: element 'sh' has %d properties (expected 9, 24 or 45 "
                                "f_rest values)" % (path, count))
        for k in range(count):
            col = sh.get("f_rest_%d" % k)
            if col is None or col.dtype != np.uint8:
                raise SplatPlyError("%s: compressed splat PLY: element 'sh' needs uchar f_rest_%d" % (path, k))
            if len(col) != n:
                raise SplatPlyError("%s: compressed splat PLY: element 'sh' has %d rows for %d splats"
                                    % (path, len(col), n))
            u = np.where(col == 0, 0.0, np.where(col == 255, 1.0, (col.astype(np.float64) + 0.5) / 256.0))
            out["f_rest_%d" % k] = ((u - 0.5) * 8.0).astype(np.float32)
    for name, col in vertex.items():
        if name not in out and not name.startswith("packed_"):
            out[name] = col
    return out
