"""Object transforms folded into 3D Gaussians: the add-on's one transform rule.

Every place where the add-on hands splats to the engine or to a file in another frame
(export with Apply Transform, F12 renders, optimisation inputs, splat PLYs referenced
by an object's "ptir_gaussians" property) goes through transform_splats here.

The rule: any invertible affine map A p + t is supported, exactly.
  - A similarity (A = s Q, Q orthogonal, a mirror allowed): p' = A p + t, scale' = s
    scale, rotation' = q(Q) q (a mirror is absorbed by flipping one local axis, which
    leaves the Gaussian unchanged), normal' = Q n. This is what the engine's own
    scene-file "transform" does (native/src/ptir/scene/scene_json.cpp), to float rounding.
  - Anything else (a non-uniform scale, a shear): the image of a Gaussian under an
    affine map is again a Gaussian, with covariance A Sigma A^T; it is re-diagonalised
    (a batched symmetric eigen-decomposition) into new standard deviations and a
    rotation. That is exact, not a fit: the Mahalanobis distance of A p + t to the new
    Gaussian equals that of p to the old one, so the density and every ray's response
    along A-mapped rays are the same. Normals map with the inverse transpose,
    normal' = A^-T n normalised (the plane of a flat Gaussian maps to the plane whose
    normal that is, which is also the new covariance's null direction).
  - Singular (a zero scale), projective or non-finite matrices raise TransformError.
Higher-order SH coefficients are not rotated (they only tint the preview colour), as
in the engine.

The engine's scene-file transform refuses what is not a similarity, so the add-on
writes a "transform" into a scene file only when similarity() accepts it, with a
tolerance 200 times stricter than the engine's; everything else it folds here.
"""

import math

import numpy as np

from ..errors import TransformError
from .splat_ply import FLT_MIN


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


def similarity(a, tol=1e-6):
    """(Q, s, mirror) when the 3x3 a is s * Q (Q orthogonal, possibly a mirror), else None.

    tol bounds |A^T A / s^2 - I| (the engine refuses above 2e-4)."""
    g = a.T @ a
    s2 = np.trace(g) / 3.0
    if s2 <= 0 or np.max(np.abs(g - s2 * np.eye(3))) > tol * s2:
        return None
    s = math.sqrt(s2)
    r = a / s
    return r, s, np.linalg.det(r) < 0


def is_similarity(matrix):
    """Whether the 4x4 affine matrix's linear part is a rotation (or mirror) times a uniform scale."""
    return similarity(np.asarray(matrix, np.float64).reshape(4, 4)[:3, :3]) is not None


def axis_scales(matrix):
    """The lengths of the 4x4 matrix's first three columns (Blender's object scale, for messages)."""
    return tuple(float(x) for x in np.linalg.norm(np.asarray(matrix, np.float64).reshape(4, 4)[:3, :3], axis=0))


def transform_splats(d, matrix, what="object transform"):
    """A new SplatData with the 4x4 affine `matrix` (row-major, column vectors) folded in.

    Identity: an exact copy. Similarity: p' = A p + t, scale' = s scale, rotation'
    = q(R) q (a mirror is absorbed by flipping one local axis, which leaves the
    Gaussian unchanged), normal' = R n. General affine: covariance A R S^2 R^T A^T
    re-diagonalised, normal' = A^-T n normalised. Raises TransformError for a
    singular, projective or non-finite matrix (the message starts with `what`).
    """
    m = np.asarray(matrix, np.float64).reshape(4, 4)
    if not np.all(np.isfinite(m)):
        raise TransformError("%s has non-finite entries" % what)
    if np.max(np.abs(m[3] - [0, 0, 0, 1])) > 1e-9:
        raise TransformError("%s is projective (last row %s); cannot fold it into splats" % (what, m[3]))
    out = d.copy()
    if np.array_equal(m, np.eye(4)):
        return out
    a, t = m[:3, :3], m[:3, 3]
    det = np.linalg.det(a)
    if abs(det) < 1e-30:
        raise TransformError("%s is singular (zero scale on some axis); cannot fold it into splats" % what)
    out.position = (d.position.astype(np.float64) @ a.T + t).astype(np.float32)
    sim = similarity(a)
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

