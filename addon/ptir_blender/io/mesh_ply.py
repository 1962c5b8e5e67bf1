"""Triangle meshes as binary little-endian PLY files (what the engine's load_mesh reads).

Written with numpy in one block (atomically): no Python loop per vertex or face.
"""

import numpy as np
from ..errors import MeshPlyError
from .atomic_file import write_atomic


def split_corners(vertices, triangles, corner_normals):
    """Per-vertex normals from per-corner ones: a vertex whose corners carry different
    normals (a sharp edge, a flat face beside smooth ones, custom split normals) is
    split into one vertex per distinct normal; corners with the same normal share one.

    vertices (n, 3), triangles (m, 3), corner_normals (m, 3, 3) (corner k of triangle
    j: corner_normals[j, k]). Returns (vertices (n', 3), normals (n', 3) unit float32,
    triangles (m, 3)).
    """
    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    cn = np.asarray(corner_normals, np.float64).reshape(-1, 3)
    length = np.linalg.norm(cn, axis=1, keepdims=True)
    cn = np.where(length > 0, cn / np.maximum(length, 1e-30), 0.0).astype(np.float32)
    # One row per corner: its vertex and its normal's bits; equal rows weld.
    keys = np.empty(len(cn), dtype=[("v", "<i8"), ("n", "<u4", (3,))])
    keys["v"] = t.reshape(-1)
    keys["n"] = cn.view(np.uint32)
    unique, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    v = np.asarray(vertices).reshape(-1, 3)[unique["v"]]
    return v, cn[first], inverse.reshape(-1, 3)


def write_mesh_ply(path, vertices, triangles, comment=None, normals=None):
    """Writes float32 vertices (n, 3) and int32 triangles (m, 3) as a binary PLY.

    Faces use the standard 'vertex_indices' list property (uchar count, int indices).
    normals (n, 3): per-vertex shading normals, written as nx, ny, nz (the engine
    interpolates them; none: flat faces). Returns path.
    """
    v = np.ascontiguousarray(np.asarray(vertices, dtype="<f4").reshape(-1, 3))
    t = np.asarray(triangles).reshape(-1, 3)
    if normals is not None:
        nrm = np.asarray(normals, dtype="<f4").reshape(-1, 3)
        if nrm.shape != v.shape:
            raise MeshPlyError("%s: %d normals for %d vertices" % (path, len(nrm), len(v)))
        if not np.all(np.isfinite(nrm)) or np.any(np.all(nrm == 0, axis=1)):
            raise MeshPlyError("%s: mesh has zero or non-finite normals" % path)
        v = np.ascontiguousarray(np.concatenate([v, nrm], axis=1))
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
    header += "element vertex %d\nproperty float x\nproperty float y\nproperty float z\n" % len(v)
    if normals is not None:
        header += "property float nx\nproperty float ny\nproperty float nz\n"
    header += "element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(t)
    return write_atomic(path, (header.encode("ascii"), v.tobytes(), faces.tobytes()), MeshPlyError)


def read_mesh_ply(path, normals=False):
    """Reads back a PLY written by write_mesh_ply (binary, float xyz, uchar/int triangle lists).

    Returns (vertices float32 (n, 3), triangles int32 (m, 3)); with normals=True,
    (vertices, triangles, normals (n, 3) or None). Only for round trips and tests.
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
    width = 6 if "property float nx" in header else 3
    vn = np.frombuffer(body, dtype="<f4", count=nv * width).reshape(nv, width)
    faces = np.frombuffer(body, dtype=[("n", "u1"), ("i", "<i4", (3,))], count=nf, offset=nv * 4 * width)
    if np.any(faces["n"] != 3):
        raise MeshPlyError("%s: faces are not all triangles" % path)
    if normals:
        return vn[:, :3].copy(), faces["i"].copy(), (vn[:, 3:].copy() if width == 6 else None)
    return vn[:, :3].copy(), faces["i"].copy()
