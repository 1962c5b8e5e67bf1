"""Writers (and a binary reader) of real-capture layouts in plain numpy, written
from the formats' documentation, independent of the engine's C++ readers:
COLMAP sparse models (binary and text), 3DGS output folders, nerfstudio and
NeRF transforms files. Poses are given as world-to-camera (R, t) in COLMAP's
convention (x_cam = R x_world + t; camera +z forward, +y down). Shared by the
dataset maker (capture.py) and the tests (tests/python/test_captures.py).
"""

import json
import struct
from pathlib import Path

import numpy as np

MODEL_IDS = {"SIMPLE_PINHOLE": 0, "PINHOLE": 1, "SIMPLE_RADIAL": 2, "RADIAL": 3, "OPENCV": 4,
             "OPENCV_FISHEYE": 5, "FULL_OPENCV": 6}
MODEL_NAMES = {v: k for k, v in MODEL_IDS.items()}
PARAM_COUNTS = {"SIMPLE_PINHOLE": 3, "PINHOLE": 4, "SIMPLE_RADIAL": 4, "RADIAL": 5, "OPENCV": 8,
                "OPENCV_FISHEYE": 8, "FULL_OPENCV": 12}


def quat_from_rotation(R):
    """Unit quaternion (w, x, y, z) of a rotation matrix (Shepperd's method), w >= 0."""
    R = np.asarray(R, np.float64)
    tr = np.trace(R)
    if tr > 0:
        s = 2.0 * np.sqrt(1.0 + tr)
        q = [0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = 2.0 * np.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        q = [(R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif R[1, 1] > R[2, 2]:
        s = 2.0 * np.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2])
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1])
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s]
    q = np.array(q)
    return q if q[0] >= 0 else -q


def rotation_from_quat(q):
    w, x, y, z = np.asarray(q, np.float64) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def opengl_c2w(R, t):
    """4x4 camera-to-world in the NeRF / OpenGL convention (camera looks down -z, +y up)."""
    R = np.asarray(R, np.float64)
    c2w = np.eye(4)
    c2w[:3, :3] = R.T @ np.diag([1.0, -1.0, -1.0])
    c2w[:3, 3] = -R.T @ np.asarray(t, np.float64)
    return c2w


def distort(model, params, x, y):
    """COLMAP's lens models on normalized coordinates (arrays), from COLMAP's documentation."""
    p = list(params)
    if model in ("SIMPLE_PINHOLE", "PINHOLE"):
        return x, y
    r2 = x * x + y * y
    if model == "SIMPLE_RADIAL":
        k = p[3]
        return x * (1 + k * r2), y * (1 + k * r2)
    if model == "RADIAL":
        radial = 1 + p[3] * r2 + p[4] * r2 * r2
        return x * radial, y * radial
    if model in ("OPENCV", "FULL_OPENCV"):
        k1, k2, p1, p2 = p[4:8]
        if model == "FULL_OPENCV":
            k3, k4, k5, k6 = p[8:12]
            radial = (1 + k1 * r2 + k2 * r2 ** 2 + k3 * r2 ** 3) / (1 + k4 * r2 + k5 * r2 ** 2 + k6 * r2 ** 3)
        else:
            radial = 1 + k1 * r2 + k2 * r2 ** 2
        return (x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
                y * radial + 2 * p2 * x * y + p1 * (r2 + 2 * y * y))
    if model == "OPENCV_FISHEYE":
        k1, k2, k3, k4 = p[4:8]
        r = np.sqrt(r2)
        th = np.arctan(r)
        thd = th * (1 + k1 * th ** 2 + k2 * th ** 4 + k3 * th ** 6 + k4 * th ** 8)
        s = np.where(r > 1e-12, thd / np.maximum(r, 1e-300), 1.0)
        return x * s, y * s
    raise ValueError(model)


def focal_centre(model, params):
    p = list(params)
    if model in ("SIMPLE_PINHOLE", "SIMPLE_RADIAL", "RADIAL"):
        return p[0], p[0], p[1], p[2]
    return p[0], p[1], p[2], p[3]


def project(model, params, R, t, X):
    """Pixel positions (n, 2) of world points X (n, 3) through a COLMAP camera."""
    Xc = (np.asarray(R) @ np.asarray(X, np.float64).T).T + np.asarray(t)
    x, y = Xc[:, 0] / Xc[:, 2], Xc[:, 1] / Xc[:, 2]
    xd, yd = distort(model, params, x, y)
    fx, fy, cx, cy = focal_centre(model, params)
    return np.stack([fx * xd + cx, fy * yd + cy], axis=1)


# --- COLMAP sparse models --------------------------------------------------------------
# cameras: {id: (model, w, h, params)}; images: [(id, q, t, camera_id, name, xy (n,2), p3d (n,))];
# points: [(id, xyz, rgb, error, [(image_id, idx), ...])]

def write_colmap_bin(folder, cameras, images, points=()):
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / "cameras.bin", "wb") as f:
        f.write(struct.pack("<Q", len(cameras)))
        for cid, (model, w, h, params) in cameras.items():
            f.write(struct.pack("<iiQQ", cid, MODEL_IDS[model], w, h))
            f.write(struct.pack("<%dd" % len(params), *params))
    with open(folder / "images.bin", "wb") as f:
        f.write(struct.pack("<Q", len(images)))
        for iid, q, t, cid, name, xy, p3d in images:
            f.write(struct.pack("<I4d3dI", iid, *q, *t, cid))
            f.write(name.encode() + b"\0")
            f.write(struct.pack("<Q", len(xy)))
            for (x, y), pid in zip(xy, p3d):
                f.write(struct.pack("<ddq", x, y, pid))
    with open(folder / "points3D.bin", "wb") as f:
        f.write(struct.pack("<Q", len(points)))
        for pid, xyz, rgb, err, track in points:
            f.write(struct.pack("<Q3d3Bd", pid, *xyz, *rgb, err))
            f.write(struct.pack("<Q", len(track)))
            for iid, idx in track:
                f.write(struct.pack("<II", iid, idx))


def write_colmap_txt(folder, cameras, images, points=()):
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / "cameras.txt", "w") as f:
        f.write("# Camera list with one line of data per camera:\n")
        for cid, (model, w, h, params) in cameras.items():
            f.write("%d %s %d %d %s\n" % (cid, model, w, h, " ".join(repr(float(p)) for p in params)))
    with open(folder / "images.txt", "w") as f:
        f.write("# Image list with two lines of data per image:\n")
        for iid, q, t, cid, name, xy, p3d in images:
            f.write("%d %s %s %d %s\n" % (iid, " ".join(repr(float(v)) for v in q), " ".join(repr(float(v)) for v in t),
                                          cid, name))
            f.write(" ".join("%r %r %d" % (float(x), float(y), pid) for (x, y), pid in zip(xy, p3d)) + "\n")
    with open(folder / "points3D.txt", "w") as f:
        f.write("# 3D point list with one line of data per point:\n")
        for pid, xyz, rgb, err, track in points:
            f.write("%d %s %d %d %d %r %s\n" % (pid, " ".join(repr(float(v)) for v in xyz), *rgb, float(err),
                                                " ".join("%d %d" % e for e in track)))


def read_colmap_bin(folder):
    folder = Path(folder)
    cameras, images, points = {}, [], []
    b = (folder / "cameras.bin").read_bytes()
    (n,), o = struct.unpack_from("<Q", b, 0), 8
    for _ in range(n):
        cid, mid, w, h = struct.unpack_from("<iiQQ", b, o)
        o += 24
        model = MODEL_NAMES[mid]
        params = struct.unpack_from("<%dd" % PARAM_COUNTS[model], b, o)
        o += 8 * PARAM_COUNTS[model]
        cameras[cid] = (model, w, h, list(params))
    b = (folder / "images.bin").read_bytes()
    (n,), o = struct.unpack_from("<Q", b, 0), 8
    for _ in range(n):
        v = struct.unpack_from("<I4d3dI", b, o)
        o += struct.calcsize("<I4d3dI")
        end = b.index(b"\0", o)
        name = b[o:end].decode()
        o = end + 1
        (np2,) = struct.unpack_from("<Q", b, o)
        o += 8
        arr = np.frombuffer(b, dtype=[("x", "<f8"), ("y", "<f8"), ("id", "<i8")], count=np2, offset=o)
        o += 24 * np2
        images.append((v[0], np.array(v[1:5]), np.array(v[5:8]), v[8], name,
                       np.stack([arr["x"], arr["y"]], 1), arr["id"].copy()))
    b = (folder / "points3D.bin").read_bytes()
    (n,), o = struct.unpack_from("<Q", b, 0), 8
    for _ in range(n):
        v = struct.unpack_from("<Q3d3Bd", b, o)
        o += struct.calcsize("<Q3d3Bd")
        (nt,) = struct.unpack_from("<Q", b, o)
        o += 8
        tr = np.frombuffer(b, dtype="<u4", count=2 * nt, offset=o).reshape(-1, 2)
        o += 8 * nt
        points.append((v[0], np.array(v[1:4]), v[4:7], v[7], [tuple(int(a) for a in e) for e in tr]))
    return cameras, images, points


# --- JSON layouts --------------------------------------------------------------------

def write_nerfstudio(path, frames, intrinsics, extra=None):
    """transforms.json: frames = [(file_path, c2w 4x4 OpenGL[, per-frame keys])]; intrinsics: top-level keys."""
    d = dict(intrinsics)
    d["frames"] = [dict({"file_path": f[0], "transform_matrix": np.asarray(f[1]).tolist()}, **(f[2] if len(f) > 2 else {}))
                   for f in frames]
    d.update(extra or {})
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(json.dumps(d, indent=1))


def write_3dgs_output(folder, source, entries, images="images", iterations=(7000, 30000)):
    """A 3DGS output folder: cameras.json (entries: name, w, h, fx, fy, R, t), cfg_args, point clouds."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    cams = []
    for i, (name, w, h, fx, fy, R, t) in enumerate(entries):
        R = np.asarray(R)
        cams.append({"id": i, "img_name": name, "width": w, "height": h,
                     "position": (-R.T @ np.asarray(t)).tolist(), "rotation": R.T.tolist(), "fy": fy, "fx": fx})
    (folder / "cameras.json").write_text(json.dumps(cams))
    (folder / "cfg_args").write_text(
        "Namespace(data_device='cuda', eval=True, images='%s', model_path='%s', resolution=-1, sh_degree=3, "
        "source_path='%s', white_background=False)" % (images, folder, source))
    for it in iterations:
        d = folder / "point_cloud" / ("iteration_%d" % it)
        d.mkdir(parents=True, exist_ok=True)
        (d / "point_cloud.ply").write_text("ply\n")
