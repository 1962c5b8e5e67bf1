"""The splat PLY layouts other tools write, from one set of splats (the engine reads all three:
native/src/ptir/io/ply*.cpp, ply_compressed.cpp).

- INRIA 3DGS (`gaussian_model.py save_ply`): float x y z nx ny nz f_dc_0..2 f_rest_0..44 opacity
  (logit) scale_0..2 (log) rot_0..3 (w x y z), normals zero.
- Mip-Splatting at SH degree 0: the same without f_rest, plus its per-splat 3D filter `filter_3D`
  (a smoothing scale the engine ignores: the file's opacity and scale are the unfiltered ones).
- 2D Gaussian Splatting (`gaussian_model.py save_ply` of hbb1/2d-gaussian-splatting): the INRIA
  columns with scale_0 and scale_1 only (surfels in the rotation's x-y plane), normals zero.
- SuperSplat / splat-transform compressed: splats in Morton order, chunks of 256 with float
  position, log-scale and colour bounds; uint packed_position (11/10/11 bits in the chunk's
  bounds), packed_rotation (largest of w x y z dropped, the other three 10 bits each in
  [-1/sqrt2, 1/sqrt2]), packed_scale (11/10/11), packed_color (r g b in the chunk's colour bounds,
  sigmoid(opacity), 8 bits each); an `sh` element of uchar f_rest, trunc((f / 8 + 0.5) * 256).
"""

import math
from pathlib import Path

import numpy as np

SH_C0 = 0.28209479177387814
GEOMETRY = ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]


def read_vertices(path):
    """The vertex records of a binary little-endian PLY whose properties are all float (as `ptir fit`
    and `ptir optimize` write them)."""
    raw = Path(path).read_bytes()
    head, body = raw.split(b"end_header\n", 1)
    names = [line.split()[-1] for line in head.decode("ascii").splitlines() if line.startswith("property")]
    return np.frombuffer(body, dtype=[(n, "<f4") for n in names]).copy()


def _write_float_ply(path, columns):
    n = len(next(iter(columns.values())))
    rec = np.zeros(n, dtype=[(name, "<f4") for name in columns])
    for name, values in columns.items():
        rec[name] = values
    header = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
    header += "".join("property float %s\n" % name for name in columns) + "end_header\n"
    Path(path).write_bytes(header.encode("ascii") + rec.tobytes())
    return Path(path)


def write_inria(path, rec, sh_rest=45):
    """The INRIA trainer's layout with the first sh_rest f_rest of rec (45: degree 3, 0: the DC only)."""
    cols = {c: rec[c] for c in "xyz"}
    cols.update({c: np.zeros(len(rec)) for c in ("nx", "ny", "nz")})
    cols.update({"f_dc_%d" % k: rec["f_dc_%d" % k] for k in range(3)})
    per_channel = sh_rest // 3
    stored = sum(1 for n in rec.dtype.names if n.startswith("f_rest_")) // 3
    for c in range(3):  # channel-major: f_rest_(c * per_channel + k)
        for k in range(per_channel):
            cols["f_rest_%d" % (c * per_channel + k)] = rec["f_rest_%d" % (c * stored + k)]
    cols.update({name: rec[name] for name in GEOMETRY})
    return _write_float_ply(path, cols)


def write_mip_splatting_sh0(path, rec, filter_3d):
    """Mip-Splatting's layout at SH degree 0: the INRIA columns without f_rest, then filter_3D."""
    cols = {c: rec[c] for c in "xyz"}
    cols.update({c: np.zeros(len(rec)) for c in ("nx", "ny", "nz")})
    cols.update({"f_dc_%d" % k: rec["f_dc_%d" % k] for k in range(3)})
    cols.update({name: rec[name] for name in GEOMETRY})
    cols["filter_3D"] = np.broadcast_to(np.asarray(filter_3d, np.float64), (len(rec),))
    return _write_float_ply(path, cols)


def write_2dgs(path, rec):
    """2DGS's layout of splats whose third axis is their thin one: the INRIA columns without scale_2."""
    cols = {c: rec[c] for c in "xyz"}
    cols.update({c: np.zeros(len(rec)) for c in ("nx", "ny", "nz")})
    cols.update({"f_dc_%d" % k: rec["f_dc_%d" % k] for k in range(3)})
    cols.update({n: rec[n] for n in sorted((n for n in rec.dtype.names if n.startswith("f_rest_")),
                                           key=lambda n: int(n[7:]))})
    cols.update({name: rec[name] for name in GEOMETRY if name != "scale_2"})
    return _write_float_ply(path, cols)


def _morton_order(pos):
    """splat-transform's ordering: the splats sorted by the Morton code of their 10-bit grid cell."""
    lo, hi = pos.min(0), pos.max(0)
    cell = np.clip(((pos - lo) / np.maximum(hi - lo, 1e-12) * 1023).astype(np.uint64), 0, 1023)
    code = np.zeros(len(pos), np.uint64)
    for bit in range(10):
        for axis in range(3):
            code |= ((cell[:, axis] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit + axis)
    return np.argsort(code, kind="stable")


def _unorm(values, lo, hi, bits):
    t = (values - lo) / np.maximum(hi - lo, 1e-12)
    return np.clip(np.round(t * ((1 << bits) - 1)), 0, (1 << bits) - 1).astype(np.uint32)


def _pack_111011(v, lo, hi):
    return (_unorm(v[:, 0], lo[:, 0], hi[:, 0], 11) << 21) | (_unorm(v[:, 1], lo[:, 1], hi[:, 1], 10) << 11) | \
        _unorm(v[:, 2], lo[:, 2], hi[:, 2], 11)


def _pack_rotation(quat):
    """Smallest three: the largest |component| dropped (its sign made positive), the rest 10 bits each."""
    q = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    n = len(q)
    big = np.argmax(np.abs(q), axis=1)
    q = q * np.where(q[np.arange(n), big] < 0, -1.0, 1.0)[:, None]
    keep = np.ones((n, 4), bool)
    keep[np.arange(n), big] = False
    rest = q[keep].reshape(n, 3)
    r = np.clip(np.round((rest / math.sqrt(2) + 0.5) * 1023), 0, 1023).astype(np.uint32)
    return (big.astype(np.uint32) << 30) | (r[:, 0] << 20) | (r[:, 1] << 10) | r[:, 2]


def write_supersplat_compressed(path, pos, log_scale, quat, f_dc, opacity_logit, f_rest=None, colour_bounds=True,
                                morton=True):
    """SuperSplat's compressed PLY of the splats (f_rest (n, 9 | 24 | 45) channel-major, or None)."""
    pos = np.asarray(pos, np.float64)
    order = _morton_order(pos) if morton else np.arange(len(pos))
    pos, log_scale, quat, f_dc, opacity_logit = (np.asarray(a, np.float64)[order]
                                                 for a in (pos, log_scale, quat, f_dc, opacity_logit))
    n = len(pos)
    colour = f_dc * SH_C0 + 0.5  # in the chunk's colour bounds; clamped to [0, 1] in files without them
    if not colour_bounds:
        colour = np.clip(colour, 0.0, 1.0)
    chunk = np.arange(n) // 256
    bounds = []
    for c in range((n + 255) // 256):
        sl = slice(256 * c, min(n, 256 * (c + 1)))
        row = [pos[sl].min(0), pos[sl].max(0), log_scale[sl].min(0), log_scale[sl].max(0)]
        if colour_bounds:
            row += [colour[sl].min(0), colour[sl].max(0)]
        bounds.append(np.concatenate(row))
    cb = np.array(bounds, np.float32)
    b = cb.astype(np.float64)[chunk]
    ppos = _pack_111011(pos, b[:, 0:3], b[:, 3:6])
    pscl = _pack_111011(log_scale, b[:, 6:9], b[:, 9:12])
    c_lo, c_hi = (b[:, 12:15], b[:, 15:18]) if colour_bounds else (np.zeros((n, 3)), np.ones((n, 3)))
    rgb = [_unorm(colour[:, k], c_lo[:, k], c_hi[:, k], 8) for k in range(3)]
    alpha = np.clip(np.round(1.0 / (1.0 + np.exp(-opacity_logit)) * 255), 0, 255).astype(np.uint32)
    pcol = (rgb[0] << 24) | (rgb[1] << 16) | (rgb[2] << 8) | alpha
    names = ["min_x", "min_y", "min_z", "max_x", "max_y", "max_z", "min_scale_x", "min_scale_y", "min_scale_z",
             "max_scale_x", "max_scale_y", "max_scale_z", "min_r", "min_g", "min_b", "max_r", "max_g", "max_b"]
    names = names[:cb.shape[1]]
    header = "ply\nformat binary_little_endian 1.0\nelement chunk %d\n" % len(cb)
    header += "".join("property float %s\n" % nm for nm in names)
    header += "element vertex %d\n" % n
    header += "".join("property uint %s\n" % nm for nm in ("packed_position", "packed_rotation", "packed_scale",
                                                           "packed_color"))
    body = np.ascontiguousarray(cb, "<f4").tobytes() + \
        np.stack([ppos, _pack_rotation(quat), pscl, pcol], 1).astype("<u4").tobytes()
    if f_rest is not None:
        f_rest = np.asarray(f_rest, np.float64)[order]
        header += "element sh %d\n" % n + "".join("property uchar f_rest_%d\n" % i for i in range(f_rest.shape[1]))
        body += np.clip(np.trunc((f_rest / 8 + 0.5) * 256), 0, 255).astype(np.uint8).tobytes()
    Path(path).write_bytes((header + "end_header\n").encode("ascii") + body)
    return Path(path)


def write_supersplat_from(path, rec):
    """The compressed PLY of a float PLY's records (every f_rest it has)."""
    rest = sorted((n for n in rec.dtype.names if n.startswith("f_rest_")), key=lambda n: int(n[7:]))
    col = lambda names: np.stack([rec[n] for n in names], 1)  # noqa: E731
    return write_supersplat_compressed(path, col("xyz"), col(["scale_%d" % k for k in range(3)]),
                                       col(["rot_%d" % k for k in range(4)]), col(["f_dc_%d" % k for k in range(3)]),
                                       rec["opacity"], col(rest) if rest else None)
