"""3D Gaussian splat PLY files <-> activated numpy arrays, without bpy.

Reading follows the engine's loader (native/src/ptir/scene/gaussian_ply.cpp)
value for value, in numpy, so the add-on imports any file the engine reads
without a per-splat Python loop:
  - the INRIA 3DGS layout, binary (either endianness) or ASCII, any numeric
    type, properties by name in any order, SH degree 0-3 (f_rest_* count 0, 9,
    24 or 45, stored channel-major);
  - SuperSplat / PlayCanvas compressed PLY (chunk + packed_* vertex words,
    optional uchar 'sh' element), decoded as the engine decodes it;
  - PTIR's material properties albedo_0..2, roughness, metallic and the normal
    nx, ny, nz (activated, linear).
Activation as the engine: scale = exp(scale_i) (at least FLT_MIN), opacity =
sigmoid(opacity) in float32, rotation = quaternion (w, x, y, z) normalised in
double. Absent material properties get the engine's defaults (albedo 0.3,
roughness 0.6, metallic 0); absent or zero normals are stored as zero vectors,
which the engine reads as "no normal: use the shortest axis".
Any other scalar vertex property is kept in `extra` (raw values) and written
back by write_splat_ply.

Errors raise SplatPlyError whose message names the file and the property.

Writing produces the standard layout
    x y z nx ny nz f_dc_0..2 f_rest_0..(3K-1) opacity scale_0..2 rot_0..3
    albedo_0..2 roughness metallic [extra properties]
as binary little-endian float32, in one numpy block.

Transform folding (transform_splats) maps a Gaussian through a 4x4 affine
matrix exactly: a similarity (rotation, uniform scale, mirror) composes the
quaternion; anything else (non-uniform scale, shear) takes the covariance
A Sigma A^T apart again (batched eigen-decomposition). Higher-order SH
coefficients are not rotated (they only tint the preview colour), as in the
engine's own transform.
"""

import math
import mmap
import os
import sys

import numpy as np

SH_C0 = 0.28209479177387814
DEFAULT_ALBEDO = 0.3
DEFAULT_ROUGHNESS = 0.6
DEFAULT_METALLIC = 0.0
FLT_MIN = np.float32(np.finfo(np.float32).tiny)
UNIT_TOLERANCE = 1e-6  # |q|^2 - 1 of a quaternion that counts as normalised

REQUIRED = ("x", "y", "z", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3", "opacity")
# Properties the reader interprets; everything else on the vertex element is "extra".
_KNOWN = set(REQUIRED) | {"nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", "albedo_0", "albedo_1", "albedo_2",
                          "roughness", "metallic"}

_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


class SplatPlyError(ValueError):
    """A file that is not a readable splat PLY, or data that cannot be written; the message says why."""


class SplatData:
    """Activated splat values as float32 numpy arrays (n rows each).

    position (n, 3); scale (n, 3) standard deviations; rotation (n, 4) unit w, x, y, z;
    opacity (n,); f_dc (n, 3) raw SH DC coefficients; sh_rest (K, n, 3) raw higher SH
    coefficients, coefficient-major (K = 0, 3, 8 or 15), sh_rest[k, :, c] = f_rest_(c*K + k);
    albedo (n, 3) linear; roughness (n,); metallic (n,); normal (n, 3) (zero = none);
    extra: {name: (n,) raw values} of other vertex properties; flags say what the file had.
    """

    FIELDS = ("position", "scale", "rotation", "opacity", "f_dc", "sh_rest", "albedo", "roughness", "metallic",
              "normal")

    def __init__(self, **kw):
        self.extra = {}
        self.has_material = False
        self.has_normals = False
        self.source = ""
        for k, v in kw.items():
            setattr(self, k, v)

    def __len__(self):
        return len(self.position)

    @property
    def sh_degree(self):
        return {0: 0, 3: 1, 8: 2, 15: 3}[self.sh_rest.shape[0]]

    def copy(self):
        out = SplatData(**{f: np.array(getattr(self, f), copy=True) for f in self.FIELDS})
        out.extra = {k: np.array(v, copy=True) for k, v in self.extra.items()}
        out.has_material, out.has_normals, out.source = self.has_material, self.has_normals, self.source
        return out

    def subset(self, index):
        out = SplatData(**{f: getattr(self, f)[index] for f in self.FIELDS if f != "sh_rest"})
        out.sh_rest = self.sh_rest[:, index]
        out.extra = {k: v[index] for k, v in self.extra.items()}
        out.has_material, out.has_normals, out.source = self.has_material, self.has_normals, self.source
        return out


def empty_like_count(n, sh_rest_count=0):
    """A SplatData of n splats with default values (identity rotations, unit scales, opacity 1)."""
    rot = np.zeros((n, 4), np.float32)
    rot[:, 0] = 1.0
    return SplatData(position=np.zeros((n, 3), np.float32), scale=np.ones((n, 3), np.float32), rotation=rot,
                     opacity=np.ones(n, np.float32), f_dc=np.zeros((n, 3), np.float32),
                     sh_rest=np.zeros((sh_rest_count, n, 3), np.float32),
                     albedo=np.full((n, 3), DEFAULT_ALBEDO, np.float32),
                     roughness=np.full(n, DEFAULT_ROUGHNESS, np.float32),
                     metallic=np.full(n, DEFAULT_METALLIC, np.float32), normal=np.zeros((n, 3), np.float32))


# ------------------------------------------------------------------ header


class _Element:
    def __init__(self, name, count):
        self.name, self.count, self.props = name, count, []  # props: (name, dtype str, list count dtype or None)

    def has_lists(self):
        return any(p[2] is not None for p in self.props)

    def get(self, name):
        return next((p for p in self.props if p[0] == name), None)


def _parse_header(data, path):
    if data[:3] != b"ply":
        raise SplatPlyError("%s: not a PLY file (it does not start with 'ply')" % path)
    end = data.find(b"end_header", 0, 1 << 20)
    if end < 0:
        raise SplatPlyError("%s: PLY header has no 'end_header'" % path)
    nl = data.find(b"\n", end, end + 64)
    if nl < 0:
        raise SplatPlyError("%s: PLY header is not terminated by a newline" % path)
    try:
        lines = data[:end].decode("ascii").replace("\r", "").split("\n")
    except UnicodeDecodeError:
        raise SplatPlyError("%s: PLY header is not ASCII text" % path)
    fmt = None
    elements = []
    for no, line in enumerate(lines[1:], 2):
        parts = line.split()
        if not parts or parts[0] in ("comment", "obj_info"):
            continue
        if parts[0] == "format":
            if len(parts) < 2 or parts[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise SplatPlyError("%s: unknown PLY format line '%s'" % (path, line))
            fmt = parts[1]
        elif parts[0] == "element":
            if len(parts) != 3 or not parts[2].isdigit():
                raise SplatPlyError("%s: bad element line '%s' (header line %d)" % (path, line, no))
            elements.append(_Element(parts[1], int(parts[2])))
        elif parts[0] == "property":
            if not elements:
                raise SplatPlyError("%s: property before any element (header line %d)" % (path, no))
            if len(parts) == 5 and parts[1] == "list":
                if parts[2] not in _TYPES or parts[3] not in _TYPES:
                    raise SplatPlyError("%s: unknown type in '%s'" % (path, line))
                elements[-1].props.append((parts[4], _TYPES[parts[3]], _TYPES[parts[2]]))
            elif len(parts) == 3:
                if parts[1] not in _TYPES:
                    raise SplatPlyError("%s: property '%s' has unknown type '%s'" % (path, parts[2], parts[1]))
                elements[-1].props.append((parts[2], _TYPES[parts[1]], None))
            else:
                raise SplatPlyError("%s: bad property line '%s' (header line %d)" % (path, line, no))
        else:
            raise SplatPlyError("%s: unexpected PLY header line '%s'" % (path, line))
    if fmt is None:
        raise SplatPlyError("%s: PLY header has no format line" % path)
    return fmt, elements, nl + 1


def _columns(rows, tile=8192):
    """(n, P) rows -> (P, n) native-endian contiguous columns, transposed tile by tile (a plain
    transpose of a large array is several times slower: every element is a cache miss)."""
    n, p = rows.shape
    out = np.empty((p, n), rows.dtype.newbyteorder("="))
    for i0 in range(0, n, tile):
        out[:, i0:i0 + tile] = rows[i0:i0 + tile].T
    return out


def read_ply_elements(path, wanted=None):
    """Reads the scalar elements of a PLY: {element name: {property: ndarray}}.

    wanted: names of the elements to return (default all). Elements with list
    properties can only be skipped when nothing wanted follows them in binary files.
    """
    try:
        with open(path, "rb") as f:
            try:  # mapped: the columns are copied straight from the page cache
                data = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
            except (ValueError, OSError):  # empty file, or a file system without mmap
                data = f.read()
    except OSError as e:
        raise SplatPlyError("%s: cannot read (%s)" % (path, e.strerror or e))
    fmt, elements, offset = _parse_header(data, path)
    names = [e.name for e in elements]
    wanted = set(names if wanted is None else wanted)
    last_wanted = max((i for i, e in enumerate(elements) if e.name in wanted), default=-1)
    out = {"__elements__": elements}
    if fmt == "ascii":
        text = data[offset:].decode("ascii", errors="replace").split("\n")
        row = 0
        for i, el in enumerate(elements):
            if i > last_wanted:
                break
            lines = text[row:row + el.count]
            row += el.count
            if el.name not in wanted:
                continue
            if el.has_lists():
                raise SplatPlyError("%s: element '%s' has list properties; a splat PLY needs scalars only"
                                    % (path, el.name))
            if len(lines) < el.count:
                raise SplatPlyError("%s: file ends inside element '%s' (%d of %d rows)"
                                    % (path, el.name, len(lines), el.count))
            try:
                flat = np.array(" ".join(lines).split(), dtype=np.float64)
            except ValueError:
                raise SplatPlyError("%s: element '%s' has a non-numeric value" % (path, el.name))
            if flat.size != el.count * len(el.props):
                raise SplatPlyError("%s: element '%s' rows do not have %d values each"
                                    % (path, el.name, len(el.props)))
            table = flat.reshape(el.count, len(el.props))
            out[el.name] = {p[0]: table[:, j].astype(p[1]) for j, p in enumerate(el.props)}
        return out
    endian = "<" if fmt == "binary_little_endian" else ">"
    for i, el in enumerate(elements):
        if i > last_wanted:
            break
        if el.has_lists():
            raise SplatPlyError("%s: element '%s' has list properties before the splat data; not a splat PLY"
                                % (path, el.name))
        seen = set()
        for p in el.props:
            if p[0] in seen:
                raise SplatPlyError("%s: element '%s' has property '%s' twice" % (path, el.name, p[0]))
            seen.add(p[0])
        dtype = np.dtype([(p[0], endian + p[1]) for p in el.props])
        size = dtype.itemsize * el.count
        if offset + size > len(data):
            raise SplatPlyError("%s: file is truncated: element '%s' needs %d bytes, %d left"
                                % (path, el.name, size, len(data) - offset))
        if el.name in wanted:
            types = {p[1] for p in el.props}
            if len(types) == 1 and el.props:
                block = _columns(np.frombuffer(data, dtype=endian + types.pop(), count=el.count * len(el.props),
                                               offset=offset).reshape(el.count, len(el.props)))
                out[el.name] = {p[0]: block[j] for j, p in enumerate(el.props)}
            else:
                rec = np.frombuffer(data, dtype=dtype, count=el.count, offset=offset)
                out[el.name] = {p[0]: np.ascontiguousarray(rec[p[0]]) for p in el.props}
        offset += size
    return out


# ------------------------------------------------------------------ reading


def _looks_like(elements, vertex):
    if any(e.name == "face" for e in elements):
        return "the file looks like a triangle mesh"
    names = {p[0] for p in vertex.props} if vertex is not None else set()
    if {"x", "y", "z"} <= names and not (names & set(REQUIRED[3:])):
        return "the file looks like a plain point cloud"
    return "the file looks like an incomplete or non-standard splat export"


def _f32(col):
    return np.ascontiguousarray(col, dtype=np.float32)


def _finite(path, name, a):
    if a.dtype.kind == "f":
        bad = ~np.isfinite(a)
        if bad.any():
            i = int(np.argmax(bad))
            raise SplatPlyError("%s: property '%s' is %s at vertex %d (first bad vertex)"
                                % (path, name, "NaN" if np.isnan(a[i]) else "infinite", i))


def _group(props, names, path):
    found = [n for n in names if n in props]
    if not found:
        return False
    if len(found) < len(names):
        raise SplatPlyError("%s: incomplete property group: missing %s"
                            % (path, ", ".join(n for n in names if n not in props)))
    return True


def _unorm(bits, width):
    return (bits & np.uint32((1 << width) - 1)).astype(np.float64) / float((1 << width) - 1)


def _decode_compressed(els, path):
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
        out["f_dc_%d" % k] = ((t - 0.5) / SH_C0).astype(np.float32)
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


def read_splat_ply(path):
    """Reads a splat PLY into a SplatData (activated values, as the engine)."""
    path = os.fspath(path)
    els = read_ply_elements(path, wanted=("vertex", "chunk", "sh"))
    elements = els["__elements__"]
    vertex_el = next((e for e in elements if e.name == "vertex"), None)
    if vertex_el is None or "vertex" not in els:
        raise SplatPlyError("%s: not a 3D Gaussian splat PLY: no 'vertex' element" % path)
    props = els["vertex"]
    if "chunk" in els and any(k.startswith("packed_") for k in props):
        props = _decode_compressed(els, path)
    missing = [p for p in REQUIRED if p not in props]
    if missing:
        raise SplatPlyError("%s: not a 3D Gaussian splat PLY: missing properties %s (%s)"
                            % (path, ", ".join(missing), _looks_like(elements, vertex_el)))
    n = vertex_el.count
    if n == 0:
        raise SplatPlyError("%s: contains no Gaussians (the vertex element has 0 rows)" % path)

    def col(name):
        c = _f32(props[name])
        _finite(path, name, c)
        return c

    position = np.stack([col("x"), col("y"), col("z")], axis=1)
    raw_scale = np.stack([col("scale_%d" % k) for k in range(3)], axis=1)
    scale = activate_scale(raw_scale)
    if not np.all(np.isfinite(scale)):
        bad = np.argwhere(~np.isfinite(scale))[0]
        raise SplatPlyError("%s: property 'scale_%d' at vertex %d is too large: exp(%g) overflows"
                            % (path, bad[1], bad[0], raw_scale[bad[0], bad[1]]))
    scale = np.maximum(scale, FLT_MIN)
    raw_op = col("opacity")
    opacity = activate_opacity(raw_op)
    q32 = np.stack([col("rot_%d" % k) for k in range(4)], axis=1)
    q = q32.astype(np.float64)
    len2 = np.sum(q * q, axis=1)
    if np.any(len2 == 0.0):
        raise SplatPlyError("%s: zero-length rotation quaternion (rot_0..rot_3 all zero) at vertex %d"
                            % (path, int(np.argmax(len2 == 0.0))))
    rotation = (q / np.sqrt(len2)[:, None]).astype(np.float32)
    # Quaternions already unit to float32 precision are kept as stored, so that a file this
    # module wrote reads back bit for bit (normalising again could move them by one ulp).
    unit = np.abs(len2 - 1.0) <= UNIT_TOLERANCE
    rotation[unit] = q32[unit]

    rest_names = [k for k in props if k.startswith("f_rest_")]
    counts = {0: 0, 9: 3, 24: 8, 45: 15}
    if len(rest_names) not in counts:
        raise SplatPlyError("%s: unsupported SH: %d f_rest_* properties (expected 0, 9, 24 or 45 for SH degree 0 "
                            "to 3)" % (path, len(rest_names)))
    K = counts[len(rest_names)]
    for i in range(3 * K):
        if "f_rest_%d" % i not in props:
            raise SplatPlyError("%s: f_rest_* properties are not numbered 0..%d: missing f_rest_%d"
                                % (path, 3 * K - 1, i))
    sh_rest = np.empty((K, n, 3), np.float32)
    for k in range(K):
        for c in range(3):
            sh_rest[k, :, c] = col("f_rest_%d" % (c * K + k))
    if _group(props, ["f_dc_0", "f_dc_1", "f_dc_2"], path):
        f_dc = np.stack([col("f_dc_%d" % k) for k in range(3)], axis=1)
    else:
        f_dc = np.zeros((n, 3), np.float32)

    has_albedo = _group(props, ["albedo_0", "albedo_1", "albedo_2"], path)
    albedo = (np.stack([col("albedo_%d" % k) for k in range(3)], axis=1) if has_albedo
              else np.full((n, 3), DEFAULT_ALBEDO, np.float32))
    roughness = col("roughness") if "roughness" in props else np.full(n, DEFAULT_ROUGHNESS, np.float32)
    metallic = col("metallic") if "metallic" in props else np.full(n, DEFAULT_METALLIC, np.float32)

    normal = np.zeros((n, 3), np.float32)
    has_normals = False
    if _group(props, ["nx", "ny", "nz"], path):
        nrm = np.stack([col("nx"), col("ny"), col("nz")], axis=1)
        length = np.sqrt(nrm[:, 0] * nrm[:, 0] + nrm[:, 1] * nrm[:, 1] + nrm[:, 2] * nrm[:, 2])
        ok = (length > 0) & np.isfinite(length)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.float32(1.0) / length
        normal[ok] = nrm[ok] * inv[ok, None]
        unit = np.abs(length.astype(np.float64) ** 2 - 1.0) <= UNIT_TOLERANCE  # kept as stored (see rotation)
        normal[unit] = nrm[unit]
        has_normals = bool(ok.all())

    extra = {}
    for name, c in props.items():
        if name in _KNOWN or name.startswith("f_rest_"):
            continue
        c = _f32(c)
        extra[name] = c
    return SplatData(position=position, scale=scale, rotation=rotation, opacity=opacity, f_dc=f_dc,
                     sh_rest=sh_rest, albedo=albedo, roughness=roughness, metallic=metallic, normal=normal,
                     extra=extra, has_material=has_albedo or "roughness" in props or "metallic" in props,
                     has_normals=has_normals, source=path)


# ------------------------------------------------------------------ activations


def activate_scale(raw):
    """exp of float32 log-scales, correctly rounded to float32, at least FLT_MIN (inf where it overflows)."""
    with np.errstate(over="ignore"):
        return np.maximum(np.exp(np.asarray(raw, np.float32).astype(np.float64)).astype(np.float32), FLT_MIN)


def activate_opacity(raw):
    """The engine's float32 sigmoid 1 / (1 + exp(-x)) (the exp correctly rounded)."""
    with np.errstate(over="ignore"):
        e = np.exp(-np.asarray(raw, np.float32).astype(np.float64)).astype(np.float32)
        return np.float32(1.0) / (np.float32(1.0) + e)


def _invert_exactly(activate, target, first_guess, steps=3):
    """float32 raw values r with activate(r) == target where one lies within `steps` ulps of the guess
    (always the case for values that were read from a file), else the guess."""
    target = np.asarray(target, np.float32)
    guess = np.asarray(first_guess, np.float32)
    best = guess.copy()
    done = activate(guess) == target
    down = up = guess
    for _ in range(steps):
        down = np.nextafter(down, np.float32(-np.inf))
        up = np.nextafter(up, np.float32(np.inf))
        for cand in (down, up):
            hit = ~done & (activate(cand) == target)
            best[hit] = cand[hit]
            done |= hit
    return best


def raw_scale(scale):
    """float32 log-scales whose activation gives back `scale` exactly when some float32 does."""
    s = np.maximum(np.asarray(scale, np.float64), float(FLT_MIN))
    return _invert_exactly(activate_scale, scale, np.log(s).astype(np.float32))


def raw_opacity(opacity):
    """float32 logits whose activation gives back `opacity` exactly when some float32 does (opacity is
    clamped to [1e-7, 1 - 1e-7] first, as the engine writes it)."""
    p = np.clip(np.asarray(opacity, np.float64), 1e-7, 1.0 - 1e-7)
    return _invert_exactly(activate_opacity, opacity, np.log(p / (1.0 - p)).astype(np.float32))


# ------------------------------------------------------------------ writing


def raw_columns(d):
    """The standard-layout raw (file) values of a SplatData: [(name, float32 (n,) array)]."""
    n = len(d)
    cols = []
    for k, axis in enumerate("xyz"):
        cols.append((axis, d.position[:, k]))
    for k, axis in enumerate(("nx", "ny", "nz")):
        cols.append((axis, d.normal[:, k]))
    for k in range(3):
        cols.append(("f_dc_%d" % k, d.f_dc[:, k]))
    K = d.sh_rest.shape[0]
    for c in range(3):
        for k in range(K):
            cols.append(("f_rest_%d" % (c * K + k), d.sh_rest[k, :, c]))
    cols.append(("opacity", raw_opacity(d.opacity)))
    raw_s = raw_scale(d.scale)
    for k in range(3):
        cols.append(("scale_%d" % k, raw_s[:, k]))
    for k in range(4):
        cols.append(("rot_%d" % k, d.rotation[:, k]))
    for k in range(3):
        cols.append(("albedo_%d" % k, d.albedo[:, k]))
    cols.append(("roughness", d.roughness))
    cols.append(("metallic", d.metallic))
    taken = {c[0] for c in cols}
    for name, v in d.extra.items():
        if name not in taken and name.replace("_", "").isalnum():
            cols.append((name, np.broadcast_to(v, (n,))))
    return cols


def validate(d, path="splats"):
    """Checks shapes and values before writing; raises SplatPlyError naming the field."""
    n = len(d.position)
    if n == 0:
        raise SplatPlyError("%s: no splats to write" % path)
    shapes = {"position": (n, 3), "scale": (n, 3), "rotation": (n, 4), "opacity": (n,), "f_dc": (n, 3),
              "albedo": (n, 3), "roughness": (n,), "metallic": (n,), "normal": (n, 3)}
    for name, shape in shapes.items():
        a = np.asarray(getattr(d, name))
        if a.shape != shape:
            raise SplatPlyError("%s: %s has shape %s, expected %s" % (path, name, a.shape, shape))
        if not np.all(np.isfinite(a)):
            raise SplatPlyError("%s: %s has non-finite values" % (path, name))
    if d.sh_rest.ndim != 3 or d.sh_rest.shape[1] != n or d.sh_rest.shape[0] not in (0, 3, 8, 15) \
            or d.sh_rest.shape[2] != 3:
        raise SplatPlyError("%s: sh_rest has shape %s, expected (0|3|8|15, n, 3)" % (path, d.sh_rest.shape))
    if np.any(d.scale <= 0):
        raise SplatPlyError("%s: scale must be positive (%d splats are not)" % (path, int(np.sum(d.scale <= 0))))
    if np.any(np.sum(np.asarray(d.rotation, np.float64) ** 2, axis=1) == 0):
        raise SplatPlyError("%s: zero-length rotation quaternion" % path)


def write_splat_ply(path, d, comment="written by the PTIR Blender add-on"):
    """Writes a SplatData as a binary little-endian float32 3DGS PLY (standard layout + materials); atomic."""
    path = os.fspath(path)
    validate(d, path)
    cols = raw_columns(d)
    n = len(d)
    rec = np.empty(n, dtype=[(name, "<f4") for name, _ in cols])
    for name, v in cols:
        rec[name] = v
    header = "ply\nformat binary_little_endian 1.0\n"
    if comment:
        header += "comment %s\n" % comment.replace("\n", " ")
    header += "element vertex %d\n" % n
    header += "".join("property float %s\n" % name for name, _ in cols) + "end_header\n"
    tmp = path + ".tmp%d" % os.getpid()
    try:
        with open(tmp, "wb") as f:
            f.write(header.encode("ascii"))
            f.write(rec.tobytes())
        os.replace(tmp, path)
    except OSError as e:
        try:
            os.remove(tmp)
        except OSError:
            pass
        raise SplatPlyError("%s: cannot write (%s)" % (path, e.strerror or e))
    return path


# ------------------------------------------------------------------ transforms


def quat_to_matrix(q):
    """(n, 4) w, x, y, z (any length) -> (n, 3, 3) rotation matrices (columns = local axes)."""
    q = np.asarray(q, np.float64)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    m = np.empty((len(q), 3, 3))
    m[:, 0, 0] = 1 - 2 * (y * y + z * z)
    m[:, 0, 1] = 2 * (x * y - w * z)
    m[:, 0, 2] = 2 * (x * z + w * y)
    m[:, 1, 0] = 2 * (x * y + w * z)
    m[:, 1, 1] = 1 - 2 * (x * x + z * z)
    m[:, 1, 2] = 2 * (y * z - w * x)
    m[:, 2, 0] = 2 * (x * z - w * y)
    m[:, 2, 1] = 2 * (y * z + w * x)
    m[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return m


def matrix_to_quat(m):
    """(n, 3, 3) proper rotation matrices -> (n, 4) unit w, x, y, z with w >= 0 (Shepperd)."""
    m = np.asarray(m, np.float64)
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    cand = np.stack([1 + tr, 1 + 2 * m[:, 0, 0] - tr, 1 + 2 * m[:, 1, 1] - tr, 1 + 2 * m[:, 2, 2] - tr], axis=1)
    big = np.argmax(cand, axis=1)
    s = 2.0 * np.sqrt(np.maximum(cand[np.arange(len(m)), big], 1e-300))
    a21, a12, a02, a20, a10, a01 = m[:, 2, 1], m[:, 1, 2], m[:, 0, 2], m[:, 2, 0], m[:, 1, 0], m[:, 0, 1]
    rows = [(s * s / 4, a21 - a12, a02 - a20, a10 - a01),
            (a21 - a12, s * s / 4, a01 + a10, a02 + a20),
            (a02 - a20, a01 + a10, s * s / 4, a12 + a21),
            (a10 - a01, a02 + a20, a12 + a21, s * s / 4)]
    q = np.empty((len(m), 4))
    for k, row in enumerate(rows):
        sel = big == k
        for c in range(4):
            q[sel, c] = row[c][sel] / s[sel]
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def quat_multiply(a, b):
    """Hamilton product a * b of (.., 4) w, x, y, z quaternions (broadcasting)."""
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def _similarity(a, tol=1e-6):
    """(R, s, mirror) when the 3x3 a is s * R (R orthogonal, possibly a mirror), else None."""
    g = a.T @ a
    s2 = np.trace(g) / 3.0
    if s2 <= 0 or np.max(np.abs(g - s2 * np.eye(3))) > tol * s2:
        return None
    s = math.sqrt(s2)
    r = a / s
    return r, s, np.linalg.det(r) < 0


def transform_splats(d, matrix):
    """A new SplatData with the 4x4 affine `matrix` (row-major, column vectors) folded in.

    Identity: an exact copy. Similarity: p' = A p + t, scale' = s scale, rotation'
    = q(R) q (a mirror is absorbed by flipping one local axis, which leaves the
    Gaussian unchanged), normal' = R n. General affine: covariance A R S^2 R^T A^T
    re-diagonalised, normal' = A^-T n normalised. Raises SplatPlyError for a
    singular or projective matrix.
    """
    m = np.asarray(matrix, np.float64).reshape(4, 4)
    if not np.all(np.isfinite(m)):
        raise SplatPlyError("object transform has non-finite entries")
    if np.max(np.abs(m[3] - [0, 0, 0, 1])) > 1e-9:
        raise SplatPlyError("object transform is projective (last row %s); cannot fold it into splats" % (m[3],))
    out = d.copy()
    if np.array_equal(m, np.eye(4)):
        return out
    a, t = m[:3, :3], m[:3, 3]
    det = np.linalg.det(a)
    if abs(det) < 1e-30:
        raise SplatPlyError("object transform is singular (zero scale on some axis); cannot fold it into splats")
    out.position = (d.position.astype(np.float64) @ a.T + t).astype(np.float32)
    sim = _similarity(a)
    nrm = d.normal.astype(np.float64)
    zero_n = ~np.any(nrm != 0, axis=1)
    if sim is not None:
        r, s, mirror = sim
        out.scale = (d.scale.astype(np.float64) * s).astype(np.float32)
        q = d.rotation.astype(np.float64)
        if mirror:
            # r R has det -1; flipping its local z axis makes it proper and leaves the covariance
            # (r R) S^2 (r R)^T unchanged, since S^2 is diagonal.
            rm = quat_to_matrix(q)
            world = np.einsum("ij,njk->nik", r, rm)
            world[:, :, 2] *= -1.0
            out.rotation = matrix_to_quat(world).astype(np.float32)
        else:
            qr = matrix_to_quat(r[None])[0]
            qn = quat_multiply(qr[None, :], q)
            qn /= np.linalg.norm(qn, axis=1, keepdims=True)
            qn *= np.where(qn[:, :1] < 0, -1.0, 1.0)
            out.rotation = qn.astype(np.float32)
        n_new = nrm @ r.T
    else:
        rm = quat_to_matrix(d.rotation)
        s2 = d.scale.astype(np.float64) ** 2
        cov = np.einsum("nij,nj,nkj->nik", rm, s2, rm)
        cov = np.einsum("ij,njk,lk->nil", a, cov, a)
        w, v = np.linalg.eigh(cov)  # ascending eigenvalues, columns = axes
        flip = np.linalg.det(v) < 0
        v[flip, :, 2] *= -1.0
        out.scale = np.sqrt(np.maximum(w, 0.0)).astype(np.float32)
        out.scale = np.maximum(out.scale, FLT_MIN)
        out.rotation = matrix_to_quat(v).astype(np.float32)
        n_new = nrm @ np.linalg.inv(a)  # rows: (A^-T n)^T = n^T A^-1
    length = np.linalg.norm(n_new, axis=1, keepdims=True)
    n_new = np.where(length > 0, n_new / np.where(length > 0, length, 1.0), 0.0)
    n_new[zero_n] = 0.0
    out.normal = n_new.astype(np.float32)
    return out


def sh_colour(d):
    """Display colour of each splat from its SH DC term: clamp(0.5 + C0 f_dc, 0, 1) (sRGB-encoded, as 3DGS)."""
    return np.clip(0.5 + SH_C0 * d.f_dc.astype(np.float64), 0.0, 1.0).astype(np.float32)


if __name__ == "__main__":  # pragma: no cover - manual inspection
    for p in sys.argv[1:]:
        s = read_splat_ply(p)
        print(p, len(s), "splats, SH degree", s.sh_degree, "extra", sorted(s.extra))
