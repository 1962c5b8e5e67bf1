"""Triangle meshes as binary little-endian PLY files (what the engine's load_mesh reads).

Written with numpy in one block (atomically): no Python loop per vertex or face.
"""

import numpy as np
from ..errors import MeshPlyError
from .atomic_file import write_atomic


def write_mesh_ply(path, vertices, triangles, comment=None):
    """Writes float32 vertices (n, 3) and int32 triangles (m, 3) as a binary PLY.

    Faces use the standard 'vertex_indices' list property (uchar count, int indices).
    Returns path.
    """
    v = np.ascontiguousarray(np.asarray(vertices, dtype="<f4").reshape(-1, 3))
    t = np.asarray(triangles).reshape(-1, 3)
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
    header += ("element vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
               "element face %d\nproperty list uchar int vertex_indices\nend_header\n" % (len(v), len(t)))
    return write_atomic(path, (header.encode("ascii"), v.tobytes(), faces.tobytes()), MeshPlyError)


def read_mesh_ply(path):
    """Reads back a PLY written by write_mesh_ply (binary, float xyz, uchar/int triangle lists).

    Returns (vertices float32 (n, 3), triangles int32 (m, 3)). Only for round trips and tests.
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
    v = np.frombuffer(body, dtype="<f4", count=nv * 3).reshape(nv, 3)
    faces = np.frombuffer(body, dtype=[("n", "u1"), ("i", "<i4", (3,))], count=nf, offset=nv * 12)
    if np.any(faces["n"] != 3):
        raise MeshPlyError("%s: faces are not all triangles" % path)
    return v.copy(), faces["i"].copy()
