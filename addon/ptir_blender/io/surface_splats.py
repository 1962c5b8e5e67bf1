"""Surfaces -> flat Gaussians, and 3DGS PLY files with PTIR's material properties.

One flat Gaussian per polygon, as a 3DGS trainer converges to on an opaque
surface: centred on the polygon's centroid, lying in its plane (local z = the
polygon's normal), spanning the polygon in-plane so that neighbours overlap into
an opaque shell, and very thin along the normal. Plain numpy functions (no bpy),
with the material and the normals written too, so the engine uses them as they
are (nx,ny,nz present -> normals_from_file). The one copy of this construction:
the sample and dataset scripts (scripts/make_sample_splat.py, scripts/dataset/)
and the tests build their splats with it, from scripts/blender_kit.world_polygons.

PLY layout written (binary little-endian float32, INRIA order first):
    x y z nx ny nz f_dc_0..2 f_rest_0..(sh_rest-1) opacity scale_0..2 rot_0..3
    [albedo_0..2 roughness metallic]
scales as log, rotation as w,x,y,z, opacity as logit; albedo linear RGB.
"""


import numpy as np
from ..errors import SplatError
from .atomic_file import write_atomic
from .sh_basis import dc_of_colour
from .splat_transform import matrix_to_quat

SPREAD = 0.6                 # in-plane sigma / polygon extent: neighbours overlap to O > 0.8 at seams
THIN = 1e-3                  # normal-axis sigma / in-plane sigma
OPACITY = 0.95


def polygons_to_gaussians(loops, start, total, spread=SPREAD, thin=THIN, skip_degenerate=False):
    """One flat Gaussian per polygon.

    loops (L, 3): the corner positions of all polygons, polygon by polygon;
    start (n,), total (n,): each polygon's first corner and corner count (start
    ascending, contiguous). Returns a dict of float64 arrays: position (n, 3),
    scale (n, 3) standard deviations (tangent, bitangent, normal), rotation (n, 4)
    w,x,y,z whose local z is the polygon's normal (right-handed winding), normal (n, 3).
    Degenerate (zero-area) polygons raise SplatError, or with skip_degenerate make no
    Gaussian: then the dict also has "keep", the (n,) mask of the polygons converted.
    """
    loops = np.asarray(loops, np.float64)
    start = np.asarray(start, np.int64)
    total = np.asarray(total, np.int64)
    n = len(start)
    if n == 0:
        raise SplatError("no polygons to convert")
    if np.any(total < 3):
        raise SplatError("every polygon needs at least 3 corners")
    poly_of_loop = np.repeat(np.arange(n), total)
    centre = np.add.reduceat(loops, start, axis=0) / total[:, None]
    # Newell's normal: robust for any (even non-planar) polygon.
    nxt = np.arange(len(loops)) + 1
    last = start + total - 1
    nxt[last] = start
    normal = np.add.reduceat(np.cross(loops, loops[nxt]), start, axis=0)
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    if np.any(length[:, 0] <= 0) and not skip_degenerate:
        raise SplatError("%d degenerate (zero-area) polygons" % int(np.sum(length[:, 0] <= 0)))
    normal /= np.maximum(length, 1e-30)  # (skipped ones: zero, and so is their bitangent below)
    # Tangent along the first edge, made orthogonal to the normal.
    t = loops[start + 1] - loops[start]
    t -= normal * np.sum(t * normal, axis=1, keepdims=True)
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-30)
    b = np.cross(normal, t)
    d = loops - centre[poly_of_loop]
    pt = np.sum(d * t[poly_of_loop], axis=1)
    pb = np.sum(d * b[poly_of_loop], axis=1)
    ext_t = np.maximum.reduceat(pt, start) - np.minimum.reduceat(pt, start)
    ext_b = np.maximum.reduceat(pb, start) - np.minimum.reduceat(pb, start)
    sigma_t, sigma_b = spread * ext_t, spread * ext_b
    sigma_n = thin * np.maximum(sigma_t, sigma_b)
    if skip_degenerate:
        keep = (sigma_t > 0) & (sigma_b > 0)
        centre, normal, t, b = centre[keep], normal[keep], t[keep], b[keep]
        sigma_t, sigma_b, sigma_n = sigma_t[keep], sigma_b[keep], sigma_n[keep]
    rot = matrix_to_quat(np.stack([t, b, normal], axis=2))
    g = {"position": centre, "scale": np.stack([sigma_t, sigma_b, sigma_n], axis=1), "rotation": rot,
         "normal": normal}
    if skip_degenerate:
        g["keep"] = keep
    return g


def triangles_to_gaussians(vertices, triangles, spread=SPREAD, thin=THIN):
    """polygons_to_gaussians for a triangle list: vertices (n, 3), triangles (m, 3)."""
    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    loops = v[t].reshape(-1, 3)
    start = np.arange(len(t), dtype=np.int64) * 3
    return polygons_to_gaussians(loops, start, np.full(len(t), 3, np.int64), spread, thin)


def linear_to_srgb(c):
    c = np.clip(np.asarray(c, np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)


def write_gaussians_ply(path, g, opacity=OPACITY, albedo=None, roughness=None, metallic=None, write_normals=True,
                        sh_rest=45, display_colour=None, comment=None, specular=None, specular_tint=None):
    """Writes Gaussians (dict of position, scale, rotation[, normal]) as a 3DGS PLY, atomically.

    opacity, albedo (linear RGB), roughness, metallic, specular and specular_tint
    (Blender's Principled inputs) broadcast to n Gaussians; the material properties
    are written only when given. The SH DC term is
    display_colour when given (display-encoded, as a trainer would store it), else
    the albedo in display (sRGB) encoding, else grey; higher SH coefficients are
    zero. Normals are written when write_normals and g has "normal" (else zeros:
    the engine then uses the shortest axis). comment: a header comment line.
    """
    pos = np.asarray(g["position"], np.float64).reshape(-1, 3)
    n = len(pos)
    scale = np.broadcast_to(np.asarray(g["scale"], np.float64), (n, 3))
    rot = np.broadcast_to(np.asarray(g["rotation"], np.float64), (n, 4))
    if np.any(scale <= 0):
        raise SplatError("%s: Gaussian scales must be positive" % path)
    names = (["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"]
             + ["f_rest_%d" % i for i in range(sh_rest)]
             + ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"])
    if albedo is not None:
        names += ["albedo_0", "albedo_1", "albedo_2"]
    if roughness is not None:
        names.append("roughness")
    if metallic is not None:
        names.append("metallic")
    fixed = [(k, v) for k, v in (("specular", specular), ("specular_tint", specular_tint)) if v is not None]
    names += [k for k, _ in fixed]
    rec = np.zeros(n, dtype=[(name, "<f4") for name in names])
    for i, axis in enumerate("xyz"):
        rec[axis] = pos[:, i]
    if write_normals and "normal" in g:
        nrm = np.broadcast_to(np.asarray(g["normal"], np.float64), (n, 3))
        for i, axis in enumerate(("nx", "ny", "nz")):
            rec[axis] = nrm[:, i]
    colour = np.broadcast_to(np.asarray(albedo if albedo is not None else (0.5, 0.5, 0.5), np.float64), (n, 3))
    if display_colour is not None:
        display = np.broadcast_to(np.asarray(display_colour, np.float64), (n, 3))
    else:
        display = linear_to_srgb(colour) if albedo is not None else colour
    for i in range(3):
        rec["f_dc_%d" % i] = dc_of_colour(display[:, i])
        rec["scale_%d" % i] = np.log(scale[:, i])
    for i in range(4):
        rec["rot_%d" % i] = rot[:, i]
    op = np.clip(np.broadcast_to(np.asarray(opacity, np.float64), (n,)), 1e-6, 1 - 1e-6)
    rec["opacity"] = np.log(op / (1.0 - op))
    if albedo is not None:
        for i in range(3):
            rec["albedo_%d" % i] = colour[:, i]
    if roughness is not None:
        rec["roughness"] = np.broadcast_to(np.asarray(roughness, np.float64), (n,))
    if metallic is not None:
        rec["metallic"] = np.broadcast_to(np.asarray(metallic, np.float64), (n,))
    for k, v in fixed:
        rec[k] = np.broadcast_to(np.asarray(v, np.float64), (n,))
    header = "ply\nformat binary_little_endian 1.0\n"
    if comment:
        header += "comment %s\n" % comment.replace("\n", " ")
    header += "element vertex %d\n" % n
    header += "".join("property float %s\n" % name for name in names) + "end_header\n"
    return write_atomic(path, (header.encode("ascii"), rec.tobytes()), SplatError)
