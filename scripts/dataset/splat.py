"""Mesh surface -> flat 3D Gaussians in the standard (INRIA) 3DGS PLY layout.

One Gaussian per polygon of the evaluated (modifiers applied) mesh: centred on
the polygon, local z = the polygon's normal, in-plane sigmas SPREAD x the
polygon's extents (neighbours overlap into an opaque shell), normal sigma THIN x
the in-plane one (a flat disc, what trainers converge to on surfaces). Stored
as trainers store them: log scales, w,x,y,z quaternion, logit opacity,
degree-3 SH (f_dc = display colour, f_rest = 0), nx,ny,nz = 0 (no normals).

The "oracle" file adds what a perfect inversion would recover -- albedo_0..2
(linear base colour), roughness, metallic and the outward face normal nx,ny,nz --
so the evaluation can be checked on a result with known answers.
"""

import math

import numpy as np

SH_C0 = 0.28209479177387814
SH_REST = 45
OPACITY = 0.95
SPREAD = 0.6
THIN = 1e-3


def world_polygons(obj, depsgraph):
    """Loop positions (world space), polygon starts, sizes and material indices of the evaluated mesh."""
    ev = obj.evaluated_get(depsgraph)
    mesh = ev.to_mesh()
    co = np.empty(len(mesh.vertices) * 3, np.float64)
    mesh.vertices.foreach_get("co", co)
    m = np.array(obj.matrix_world)
    co = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    n_poly = len(mesh.polygons)
    start = np.empty(n_poly, np.int64)
    total = np.empty(n_poly, np.int64)
    mat = np.empty(n_poly, np.int64)
    mesh.polygons.foreach_get("loop_start", start)
    mesh.polygons.foreach_get("loop_total", total)
    mesh.polygons.foreach_get("material_index", mat)
    loop_vert = np.empty(len(mesh.loops), np.int64)
    mesh.loops.foreach_get("vertex_index", loop_vert)
    ev.to_mesh_clear()
    order = np.argsort(start)
    start, total, mat = start[order], total[order], mat[order]
    # Loops in polygon order, so reduceat over the starts sums per polygon.
    idx = np.concatenate([np.arange(s, s + t) for s, t in zip(start, total)]) if n_poly else np.zeros(0, np.int64)
    loops = co[loop_vert[idx]]
    new_start = np.concatenate([[0], np.cumsum(total)[:-1]]) if n_poly else start
    return loops, new_start, total, mat


def matrices_to_quaternions(r):
    """(n, 3, 3) rotation matrices (columns = local axes) -> (n, 4) unit w, x, y, z with w >= 0."""
    m = r
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    cand = np.stack([1 + tr, 1 + 2 * m[:, 0, 0] - tr, 1 + 2 * m[:, 1, 1] - tr, 1 + 2 * m[:, 2, 2] - tr], axis=1)
    big = np.argmax(cand, axis=1)
    s = 2.0 * np.sqrt(np.maximum(cand[np.arange(len(m)), big], 1e-12))
    a21, a12 = m[:, 2, 1], m[:, 1, 2]
    a02, a20 = m[:, 0, 2], m[:, 2, 0]
    a10, a01 = m[:, 1, 0], m[:, 0, 1]
    q = np.empty((len(m), 4))
    rows = [(s * s / 4, a21 - a12, a02 - a20, a10 - a01),
            (a21 - a12, s * s / 4, a01 + a10, a02 + a20),
            (a02 - a20, a01 + a10, s * s / 4, a12 + a21),
            (a10 - a01, a02 + a20, a12 + a21, s * s / 4)]
    for k, row in enumerate(rows):
        sel = big == k
        for c in range(4):
            q[sel, c] = row[c][sel] / s[sel]
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def polygons_to_gaussians(loops, start, total):
    """Centre, sigmas (n, 3), rotation (n, 4) and outward normal (n, 3) of one flat Gaussian per polygon."""
    n = len(start)
    poly_of_loop = np.repeat(np.arange(n), total)
    centre = np.add.reduceat(loops, start, axis=0) / total[:, None]
    nxt = np.arange(len(loops)) + 1
    nxt[start + total - 1] = start
    normal = np.add.reduceat(np.cross(loops, loops[nxt]), start, axis=0)  # Newell: follows the winding (outward)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
    t = loops[start + 1] - loops[start]
    t -= normal * np.sum(t * normal, axis=1, keepdims=True)
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-30)
    b = np.cross(normal, t)
    d = loops - centre[poly_of_loop]
    pt = np.sum(d * t[poly_of_loop], axis=1)
    pb = np.sum(d * b[poly_of_loop], axis=1)
    ext_t = np.maximum.reduceat(pt, start) - np.minimum.reduceat(pt, start)
    ext_b = np.maximum.reduceat(pb, start) - np.minimum.reduceat(pb, start)
    sigma_t, sigma_b = SPREAD * ext_t, SPREAD * ext_b
    sigma_n = THIN * np.maximum(sigma_t, sigma_b)
    keep = (sigma_t > 0) & (sigma_b > 0)  # degenerate polygons make no Gaussian
    rot = matrices_to_quaternions(np.stack([t, b, normal], axis=2))
    return {"position": centre[keep], "scale": np.stack([sigma_t, sigma_b, sigma_n], 1)[keep],
            "rotation": rot[keep], "normal": normal[keep]}, keep


def write_gaussians_ply(path, g, oracle=False):
    """INRIA 3DGS layout (binary little-endian float32). g: position, scale, rotation,
    display_colour (sRGB-ish, for the SH preview); with oracle=True also albedo,
    roughness, metallic and normal."""
    names = (["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"]
             + ["f_rest_%d" % i for i in range(SH_REST)]
             + ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"])
    if oracle:
        names += ["albedo_0", "albedo_1", "albedo_2", "roughness", "metallic"]
    n = len(g["position"])
    rec = np.zeros(n, dtype=[(name, "<f4") for name in names])
    for i, axis in enumerate("xyz"):
        rec[axis] = g["position"][:, i]
    for i in range(3):
        rec["f_dc_%d" % i] = (g["display_colour"][:, i] - 0.5) / SH_C0
        rec["scale_%d" % i] = np.log(g["scale"][:, i])
    for i in range(4):
        rec["rot_%d" % i] = g["rotation"][:, i]
    rec["opacity"] = math.log(OPACITY / (1.0 - OPACITY))
    if oracle:
        for i, axis in enumerate(("nx", "ny", "nz")):
            rec[axis] = g["normal"][:, i]
        for i in range(3):
            rec["albedo_%d" % i] = g["albedo"][:, i]
        rec["roughness"] = g["roughness"]
        rec["metallic"] = g["metallic"]
    header = "ply\nformat binary_little_endian 1.0\n"
    header += "comment PTIR dataset maker: flat Gaussians from the mesh surface%s\n" % (
        " + ground-truth materials (oracle)" if oracle else "")
    header += "element vertex %d\n" % n
    header += "".join("property float %s\n" % name for name in names) + "end_header\n"
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(rec.tobytes())
