"""Triangle meshes as binary little-endian PLY files (what the engine's load_mesh reads).

Written with numpy in one block (atomically): no Python loop per vertex or face.
"""

import numpy as np
from ..errors import MeshPlyError
from .atomic_file import write_atomic


def split_corner_attributes(vertices, triangles, **corner_attributes):
    """Per-vertex attributes from per-corner ones: a vertex whose corners differ in any
    attribute (a sharp edge's normals, a UV seam, a flat face beside smooth ones) is split
    into one vertex per distinct combination; corners that agree share one.

    vertices (n, 3), triangles (m, 3), each attribute (m, 3, k) (corner c of triangle j:
    attribute[j, c]; None: absent). Returns (vertices (n', 3), {name: (n', k) float32},
    triangles (m, 3)).
    """
    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    attrs = {}
    for name, a in corner_attributes.items():
        if a is not None:
            a = np.asarray(a, np.float64)
            attrs[name] = a.reshape(len(t) * 3, -1).astype(np.float32)
    # One row per corner: its vertex and its attributes' bits; equal rows weld.
    fields = [("v", "<i8")] + [(name, "<u4", (a.shape[1],)) for name, a in attrs.items()]
    keys = np.empty(len(t) * 3, dtype=fields)
    keys["v"] = t.reshape(-1)
    for name, a in attrs.items():
        keys[name] = np.ascontiguousarray(a).view(np.uint32)
    unique, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    v = np.asarray(vertices).reshape(-1, 3)[unique["v"]]
    return v, {name: a[first] for name, a in attrs.items()}, inverse.reshape(-1, 3)


def split_corners(vertices, triangles, corner_normals):
    """split_corner_attributes for normals alone (made unit): returns (vertices (n', 3),
    normals (n', 3) unit float32, triangles (m, 3))."""
    cn = np.asarray(corner_normals, np.float64).reshape(-1, 3)
    length = np.linalg.norm(cn, axis=1, keepdims=True)
    cn = np.where(length > 0, cn / np.maximum(length, 1e-30), 0.0)
    v, attrs, t = split_corner_attributes(vertices, triangles, normals=cn.reshape(-1, 3, 3))
    return v, attrs["normals"], t


def write_mesh_ply(path, vertices, triangles, comment=None, normals=None, uvs=None, tangents=None):
    """Writes float32 vertices (n, 3) and int32 triangles (m, 3) as a binary PLY.

    Faces use the standard 'vertex_indices' list property (uchar count, int indices).
    normals (n, 3): per-vertex shading normals, written as nx, ny, nz (the engine
    interpolates them; none: flat faces). uvs (n, 2): texture coordinates, written as
    s, t. tangents (n, 4): the UV map's tangent and bitangent sign, written as tx, ty,
    tz, tw. Returns path.
    """
    v = np.ascontiguousarray(np.asarray(vertices, dtype="<f4").reshape(-1, 3))
    t = np.asarray(triangles).reshape(-1, 3)
    columns, names = [v], ["x", "y", "z"]
    if normals is not None:
        nrm = np.asarray(normals, dtype="<f4").reshape(-1, 3)
        if nrm.shape != v.shape:
            raise MeshPlyError("%s: %d normals for %d vertices" % (path, len(nrm), len(v)))
        if not np.all(np.isfinite(nrm)) or np.any(np.all(nrm == 0, axis=1)):
            raise MeshPlyError("%s: mesh has zero or non-finite normals" % path)
        columns.append(nrm)
        names += ["nx", "ny", "nz"]
    for what, a, k, cols in (("texture coordinates", uvs, 2, ["s", "t"]), ("tangents", tangents, 4, ["tx", "ty", "tz", "tw"])):
        if a is None:
            continue
        a = np.asarray(a, dtype="<f4").reshape(-1, k)
        if len(a) != len(v) or not np.all(np.isfinite(a)):
            raise MeshPlyError("%s: %d %s for %d vertices (or non-finite ones)" % (path, len(a), what, len(v)))
        columns.append(a)
        names += cols
    v = np.ascontiguousarray(np.concatenate(columns, axis=1))
    if len(t) == 0:
        raise MeshPlyError("%s: a mesh needs at least one triangle" % path)
    if not np.all(np.isfinite(v)):
        raise MeshPlyError("%s: mesh has non-finite vertex coordinates" % path)
    if t.min() < 0 or t.max() >= len(v):
        raise MeshPlyError("%s: triangle index out of range (%d vertices)" % (path, len(v)))
    faces = np.empty(len(t), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    faces["n"] = 3
    faces["i"] = t.astype("<i4")
    header = "ply\nformat binary_little_endian 1.0\n"
    if comment:
        header += "comment %s\n" % comment.replace("\n", " ")
    header += "element vertex %d\n" % len(v) + "".join("property float %s\n" % n for n in names)
    header += "element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(t)
    return write_atomic(path, (header.encode("ascii"), v.tobytes(), faces.tobytes()), MeshPlyError)


def read_mesh_ply(path, normals=False, columns=None):
    """Reads back a PLY written by write_mesh_ply (binary, float xyz, uchar/int triangle lists).

    Returns (vertices float32 (n, 3), triangles int32 (m, 3)); with normals=True,
    (vertices, triangles, normals (n, 3) or None); with columns=[names], (vertices, triangles,
    {name: (n,) values}). Only for round trips and tests.
    """
    with open(path, "rb") as f:
        data = f.read()
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        raise MeshPlyError("%s: not a PLY file" % path)
    header = data[:end].decode("ascii").splitlines()
    if "format binary_little_endian 1.0" not in header:
        raise MeshPlyError("%s: only binary little-endian PLY is read here" % path)
    nv = nf = None
    for line in header:
        parts = line.split()
        if parts[:2] == ["element", "vertex"]:
            nv = int(parts[2])
        elif parts[:2] == ["element", "face"]:
            nf = int(parts[2])
    body = data[end + len(b"end_header\n"):]
    names = [line.split()[2] for line in header if line.startswith("property float")]
    width = len(names)
    vn = np.frombuffer(body, dtype="<f4", count=nv * width).reshape(nv, width)
    faces = np.frombuffer(body, dtype=[("n", "u1"), ("i", "<i4", (3,))], count=nf, offset=nv * 4 * width)
    if np.any(faces["n"] != 3):
        raise MeshPlyError("%s: faces are not all triangles" % path)
    if columns:
        return vn[:, :3].copy(), faces["i"].copy(), {c: vn[:, names.index(c)].copy() for c in columns}
    if normals:
        return vn[:, :3].copy(), faces["i"].copy(), (vn[:, 3:6].copy() if "nx" in names else None)
    return vn[:, :3].copy(), faces["i"].copy()
