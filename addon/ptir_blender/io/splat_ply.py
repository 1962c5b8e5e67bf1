"""3D Gaussian splat PLY files <-> activated numpy arrays, without bpy.

Reading follows the engine's loader (native/src/ptir/scene/gaussian_ply.cpp)
value for value, in numpy, so the add-on imports any file the engine reads
without a per-splat Python loop:
  - the INRIA 3DGS layout, binary (either endianness) or ASCII, any numeric
    type, properties by name in any order, SH degree 0-4 (f_rest_* count 0, 9,
    24, 45 or 72, stored channel-major);
  - SuperSplat / PlayCanvas compressed PLY (chunk + packed_* vertex words,
    optional uchar 'sh' element), decoded as the engine decodes it
    (supersplat_ply.py);
  - PTIR's material properties albedo_0..2, roughness, metallic and the normal
    nx, ny, nz (activated, linear);
  - 2D Gaussian Splatting's surfels (scale_0 and scale_1 only): flat splats whose
    third scale is SURFEL_THICKNESS x the smaller of the two, as the engine reads
    them (written back in the standard layout, with that third scale).
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
as binary little-endian float32, in one numpy block, atomically.

Transforms are folded into splats by splat_transform.py.
"""

import mmap
import os
import sys

import numpy as np

from ..errors import SplatPlyError
from . import supersplat_ply
from .atomic_file import write_atomic
from .sh_basis import SH_C0  # noqa: F401 (part of this module's interface: splat_ply.SH_C0)

DEFAULT_ALBEDO = 0.3
DEFAULT_ROUGHNESS = 0.6
DEFAULT_METALLIC = 0.0
FLT_MIN = np.float32(np.finfo(np.float32).tiny)
UNIT_TOLERANCE = 1e-6  # |q|^2 - 1 of a quaternion that counts as normalised
# A 2DGS surfel's thickness as a share of its smaller scale (the engine's kSurfelThickness,
# scene/gaussian_ply.h): the smallest axis, so the surfel's normal is its shortest axis.
SURFEL_THICKNESS = np.float32(1e-3)

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
        return {0: 0, 3: 1, 8: 2, 15: 3, 24: 4}[self.sh_rest.shape[0]]

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


def read_splat_ply(path):
    """Reads a splat PLY into a SplatData (activated values, as the engine)."""
    path = os.fspath(path)
    els = read_ply_elements(path, wanted=("vertex", "chunk", "sh"))
    elements = els["__elements__"]
    vertex_el = next((e for e in elements if e.name == "vertex"), None)
    if vertex_el is None or "vertex" not in els:
        raise SplatPlyError("%s: not a 3D Gaussian splat PLY: no 'vertex' element" % path)
    props = els["vertex"]
    if supersplat_ply.is_compressed(els):
        props = supersplat_ply.decode_compressed(els, path)
    surfels = "scale_0" in props and "scale_1" in props and "scale_2" not in props  # 2DGS
    missing = [p for p in REQUIRED if p not in props and not (surfels and p == "scale_2")]
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
    raw_scale = np.stack([col("scale_%d" % k) for k in range(2 if surfels else 3)], axis=1)
    scale = activate_scale(raw_scale)
    if not np.all(np.isfinite(scale)):
        bad = np.argwhere(~np.isfinite(scale))[0]
        raise SplatPlyError("%s: property 'scale_%d' at vertex %d is too large: exp(%g) overflows"
                            % (path, bad[1], bad[0], raw_scale[bad[0], bad[1]]))
    scale = np.maximum(scale, FLT_MIN)
    if surfels:
        scale = np.concatenate([scale, SURFEL_THICKNESS * np.minimum(scale[:, :1], scale[:, 1:])], axis=1)
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
    counts = {0: 0, 9: 3, 24: 8, 45: 15, 72: 24}
    if len(rest_names) not in counts:
        raise SplatPlyError("%s: unsupported SH: %d f_rest_* properties (expected 0, 9, 24, 45 or 72 for SH degree "
                            "0 to 4)" % (path, len(rest_names)))
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
    if d.sh_rest.ndim != 3 or d.sh_rest.shape[1] != n or d.sh_rest.shape[0] not in (0, 3, 8, 15, 24) \
            or d.sh_rest.shape[2] != 3:
        raise SplatPlyError("%s: sh_rest has shape %s, expected (0|3|8|15|24, n, 3)" % (path, d.sh_rest.shape))
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
    return write_atomic(path, (header.encode("ascii"), rec.tobytes()), SplatPlyError)


if __name__ == "__main__":  # pragma: no cover - manual inspection
    for p in sys.argv[1:]:
        s = read_splat_ply(p)
        print(p, len(s), "splats, SH degree", s.sh_degree, "extra", sorted(s.extra))
