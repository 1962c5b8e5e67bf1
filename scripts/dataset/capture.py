"""One synthetic capture written in every layout PTIR reads, so results can be
compared layout against layout (pure numpy; used by scripts/make_dataset.py
--capture-layouts and by tests/python/test_capture_layouts.py).

Input: pinhole renders of the views (linear RGB with the environment behind the
object, and the object's coverage as the mask) and their OpenGL camera-to-world
matrices. Output, under OUT/:

    nerf/         transforms_train.json + transforms_test.json (pinhole fl_x/fl_y/cx/cy),
                  images/<name>.png RGBA (alpha = mask) or RGB without masks
    colmap_bin/   sparse/0/{cameras,images,points3D}.bin, one distorted camera (LENS),
                  images/<name>.png (RGB photos through that lens), masks/<name>.png
    colmap_txt/   the same model as text files
    nerfstudio/   transforms.json (camera_model OPENCV, k1 k2 p1 p2), images/, masks/ (mask_path)

Every layout holds the same views; NeRF's test split is every 8th view in name
order, which is what the capture layouts hold out by default (--holdout 8).

Distorted photos: the lens keeps the pinhole's fx, fy, cx, cy; each photo pixel
is the pinhole render sampled (bilinearly, in sRGB-encoded values as the
undistorter resamples) where the lens sends that pixel's ray. The default lens is
pincushion (k1 > 0: a photo pixel's ray lies inside the pinhole frame), so the
render covers the whole photo; the tangential terms are small enough that the
few edge samples they push out are clamped to the border pixel.
"""

import math
from pathlib import Path

import numpy as np

from . import envmaps, layouts, png

# OPENCV: fx, fy, cx, cy are the render's; k1, k2, p1, p2 these.
DEFAULT_DISTORTION = (0.05, 0.01, 0.0005, -0.0004)
LAYOUTS = ("nerf", "colmap_bin", "colmap_txt", "nerfstudio")


def undistort_points(model, params, xd, yd, iterations=30):
    """Normalised pinhole coordinates whose distortion is (xd, yd): Newton's method
    on layouts.distort with a central-difference Jacobian."""
    x, y = np.array(xd, np.float64), np.array(yd, np.float64)
    h = 1e-7
    for _ in range(iterations):
        fx, fy = layouts.distort(model, params, x, y)
        ex, ey = fx - xd, fy - yd
        ax, ay = layouts.distort(model, params, x + h, y)
        bx, by = layouts.distort(model, params, x, y + h)
        j11, j21, j12, j22 = (ax - fx) / h, (ay - fy) / h, (bx - fx) / h, (by - fy) / h
        det = j11 * j22 - j12 * j21
        x = x - (j22 * ex - j12 * ey) / det
        y = y - (-j21 * ex + j11 * ey) / det
        if max(np.abs(ex).max(initial=0.0), np.abs(ey).max(initial=0.0)) < 1e-13:
            break
    return x, y


def bilinear(img, u, v):
    """img (h, w, c) sampled at pixel positions (u, v) (pixel centres at +0.5), border-clamped."""
    h, w = img.shape[:2]
    x = np.clip(u - 0.5, 0.0, w - 1.0)
    y = np.clip(v - 0.5, 0.0, h - 1.0)
    x0, y0 = np.minimum(np.floor(x).astype(int), w - 2), np.minimum(np.floor(y).astype(int), h - 2)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    return ((1 - fy) * ((1 - fx) * img[y0, x0] + fx * img[y0, x0 + 1])
            + fy * ((1 - fx) * img[y0 + 1, x0] + fx * img[y0 + 1, x0 + 1]))


def distort_image(img, model, params):
    """A photo through `model` (same image size and fx, fy, cx, cy) from a pinhole image."""
    h, w = img.shape[:2]
    fx, fy, cx, cy = layouts.focal_centre(model, params)
    u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    x, y = undistort_points(model, params, (u - cx) / fx, (v - cy) / fy)
    return bilinear(np.asarray(img, np.float64), fx * x + cx, fy * y + cy)


def w2c_from_opengl(c2w):
    """COLMAP world-to-camera (R, t) of an OpenGL camera-to-world matrix (inverse of layouts.opengl_c2w)."""
    c2w = np.asarray(c2w, np.float64)
    Rc = c2w[:3, :3] @ np.diag([1.0, -1.0, -1.0])  # COLMAP camera axes in the world (columns)
    return Rc.T, -Rc.T @ c2w[:3, 3]


def composite_over_environment(rgba, c2w, intrinsics, env):
    """A photo of a transparent-film render (premultiplied linear RGBA): the environment
    map (lat-long, Blender's orientation) seen through each pixel centre behind the object."""
    h, w = rgba.shape[:2]
    fx, fy, cx, cy = intrinsics
    u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    d_cam = np.stack([(u - cx) / fx, -(v - cy) / fy, -np.ones_like(u)], -1)  # OpenGL camera axes
    d = d_cam @ np.asarray(c2w, np.float64)[:3, :3].T
    a = rgba[..., 3:4]
    return rgba[..., :3] + (1.0 - a) * envmaps.lookup(env, d)


def holdout_plan(train, test, holdout=8):
    """A capture's views in name order from a set's: k test views at 0, holdout, 2 holdout, ...
    (k the fewest that the holdout picks with all the training views), the training views in
    order between them, so that `--holdout` trains on exactly the set's training views."""
    k = math.ceil(len(train) / (holdout - 1))
    if k > len(test):
        raise ValueError("%d training views need %d test views at every %dth position, the set has %d"
                         % (len(train), k, holdout, len(test)))
    tests, trains = iter(test[:k]), iter(train)
    return [next(tests) if i % holdout == 0 else next(trains) for i in range(len(train) + k)]


def _photo_8bit(rgb_linear):
    return png.srgb_encode(rgb_linear)


def box_downsample(img, k):
    """Mean of each k x k block (k = 1: img itself)."""
    if k == 1:
        return img
    h, w = img.shape[0] // k, img.shape[1] // k
    return img[:h * k, :w * k].reshape(h, k, w, k, -1).mean(axis=(1, 3))


def write_capture_layouts(out, views, intrinsics, distortion=DEFAULT_DISTORTION, masks=True, holdout=8,
                          layouts_wanted=LAYOUTS, supersample=1, extra=None):
    """views: [(name, c2w OpenGL 4x4, rgb linear (h, w, 3), mask (h, w) in [0, 1])] in any order,
    rendered at `supersample` times the output size; intrinsics: (fx, fy, cx, cy) of the
    output-size pinhole. Every photo is box-filtered down to the output size (after the
    lens warp, which is done at the render's resolution). extra: top-level keys added to every
    transforms JSON written (the NeRF and nerfstudio layouts). Returns {layout: folder}."""
    out = Path(out)
    k = int(supersample)
    views = sorted(views, key=lambda v: v[0])
    h, w = views[0][2].shape[0] // k, views[0][2].shape[1] // k
    fx, fy, cx, cy = (float(v) for v in intrinsics)
    lens = ("OPENCV", [fx, fy, cx, cy, *(float(d) for d in distortion)])
    lens_k = ("OPENCV", [k * fx, k * fy, k * cx, k * cy, *(float(d) for d in distortion)])
    made = {}
    encoded_k = [(name, c2w, _photo_8bit(rgb), np.clip(mask, 0.0, 1.0)) for name, c2w, rgb, mask in views]
    encoded = [(name, c2w, box_downsample(enc, k), box_downsample(mask[..., None], k)[..., 0])
               for name, c2w, enc, mask in encoded_k]
    if "nerf" in layouts_wanted:
        root = out / "nerf"
        test = {i for i in range(0, len(encoded), holdout)} if holdout > 0 else set()
        pin = {"fl_x": fx, "fl_y": fy, "cx": cx, "cy": cy, "w": w, "h": h}
        for split, keep in (("train", lambda i: i not in test), ("test", lambda i: i in test)):
            frames = [("images/%s.png" % name, c2w) for i, (name, c2w, _, _) in enumerate(encoded) if keep(i)]
            layouts.write_nerfstudio(root / ("transforms_%s.json" % split), frames, pin, extra)
        (root / "images").mkdir(parents=True, exist_ok=True)
        for name, _, enc, mask in encoded:
            px = np.concatenate([enc, mask[..., None]], -1) if masks else enc
            png.write_png(root / "images" / (name + ".png"), png.to_8bit(px))
        made["nerf"] = root
    distorted = [(name, c2w, box_downsample(distort_image(enc, *lens_k), k),
                  box_downsample(distort_image(mask[..., None], *lens_k), k)[..., 0])
                 for name, c2w, enc, mask in encoded_k] if set(layouts_wanted) - {"nerf"} else []

    def photos(root):
        (root / "images").mkdir(parents=True, exist_ok=True)
        if masks:
            (root / "masks").mkdir(parents=True, exist_ok=True)
        for name, _, enc, mask in distorted:
            png.write_png(root / "images" / (name + ".png"), png.to_8bit(enc))
            if masks:
                png.write_png(root / "masks" / (name + ".png"), png.to_8bit(mask))

    for kind in ("colmap_bin", "colmap_txt"):
        if kind not in layouts_wanted:
            continue
        root = out / kind
        cams = {1: (lens[0], w, h, lens[1])}
        imgs = [(i + 1, layouts.quat_from_rotation(R), t, 1, name + ".png", np.zeros((0, 2)), np.zeros(0, np.int64))
                for i, (name, c2w, _, _) in enumerate(distorted) for R, t in [w2c_from_opengl(c2w)]]
        (layouts.write_colmap_bin if kind == "colmap_bin" else layouts.write_colmap_txt)(root / "sparse" / "0", cams, imgs)
        photos(root)
        made[kind] = root
    if "nerfstudio" in layouts_wanted:
        root = out / "nerfstudio"
        k1, k2, p1, p2 = lens[1][4:8]
        intr = {"camera_model": "OPENCV", "fl_x": fx, "fl_y": fy, "cx": cx, "cy": cy, "w": w, "h": h,
                "k1": k1, "k2": k2, "p1": p1, "p2": p2}
        frames = [("images/%s.png" % name, c2w, {"mask_path": "masks/%s.png" % name} if masks else {})
                  for name, c2w, _, _ in distorted]
        layouts.write_nerfstudio(root / "transforms.json", frames, intr, extra)
        photos(root)
        made["nerfstudio"] = root
    return made
