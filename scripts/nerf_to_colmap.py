#!/usr/bin/python3
"""A NeRF-layout set (scripts/make_dataset.py's) written as a COLMAP capture with
masks: the same pixels, poses and masks, so `ptir optimize` on either gives the
same answer (issue 38: docs/captures.md, "The same set as COLMAP and as NeRF").

    scripts/nerf_to_colmap.py NERF_DIR OUT_DIR [--text]

Writes OUT_DIR/sparse/0/{cameras,images,points3D}.bin (.txt with --text): one
PINHOLE camera with the set's fx = fy = w / (2 tan(camera_angle_x / 2)) and
principal point at the image centre (COLMAP's pixel centres are at +0.5, as the
NeRF convention's), each view's pose (world to camera, COLMAP's axes), no 3D
points (ptir takes the splats from --gaussians); OUT_DIR/images/NAME.png, the
RGB of the view's RGBA PNG as stored (straight sRGB-encoded colour, black where
alpha is 0); OUT_DIR/masks/NAME.png, its alpha as an 8-bit grey mask; and the
set's dataset.json (the record of how the images were rendered: the pixel
filter, the Blender and so the surface model), which ptir reads in every layout.

The split: a capture holds out every 8th image in name order (`--holdout 8`, the
default). So that the capture's training views are exactly the set's, k =
ceil(train / 7) of the set's test views are written at positions 0, 8, 16, ...
and the training views fill the rest in order; NAME is "<position>_<the set's
view name>" ("000_test_000", "001_train_000", ...), so name order is position
order. The set's own test views (ground truth) stay where `ptir eval --dataset
NERF_DIR` reads them.
"""

import argparse
import json
import math
import shutil
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from dataset import capture, layouts, png  # noqa: E402


def read_png(path):
    import skimage.io  # the tests' image reader (a dependency of make test)
    return np.asarray(skimage.io.imread(str(path)))


def frames_of(root, split):
    t = json.loads((root / ("transforms_%s.json" % split)).read_text())
    out = []
    for f in t["frames"]:
        rel = f["file_path"]
        p = root / rel
        if p.suffix.lower() != ".png":
            p = p.with_name(p.name + ".png")
        name = Path(rel).parent.name if Path(rel).stem == "rgba" else Path(rel).stem  # TensoIR: the view's folder
        out.append((name, np.asarray(f["transform_matrix"], np.float64), p))
    return t, out


def plan(train, test, holdout=8):
    """The capture's views in name order (dataset/capture.py's holdout_plan)."""
    try:
        return capture.holdout_plan(train, test, holdout)
    except ValueError as e:
        raise SystemExit("nerf_to_colmap: %s" % e)


def convert(nerf_dir, out_dir, text=False):
    root, out = Path(nerf_dir), Path(out_dir)
    meta, train = frames_of(root, "train")
    _, test = frames_of(root, "test")
    views = plan(train, test)
    first = read_png(views[0][2])
    h, w = first.shape[:2]
    f = 0.5 * w / math.tan(0.5 * float(meta["camera_angle_x"]))
    cams = {1: ("PINHOLE", w, h, [f, f, 0.5 * w, 0.5 * h])}
    imgs = []
    (out / "images").mkdir(parents=True, exist_ok=True)
    (out / "masks").mkdir(parents=True, exist_ok=True)
    for i, (name, c2w, path) in enumerate(views):
        rgba = read_png(path)
        if rgba.ndim != 3 or rgba.shape[2] != 4 or rgba.dtype != np.uint8 or rgba.shape[:2] != (h, w):
            raise SystemExit("nerf_to_colmap: %s: expected an 8-bit RGBA PNG of %dx%d" % (path, w, h))
        stem = "%03d_%s" % (i, name)
        png.write_png(out / "images" / (stem + ".png"), np.ascontiguousarray(rgba[..., :3]))
        png.write_png(out / "masks" / (stem + ".png"), np.ascontiguousarray(rgba[..., 3]))
        R, t = capture.w2c_from_opengl(c2w)
        imgs.append((i + 1, layouts.quat_from_rotation(R), t, 1, stem + ".png", np.zeros((0, 2)), np.zeros(0, np.int64)))
    (layouts.write_colmap_txt if text else layouts.write_colmap_bin)(out / "sparse" / "0", cams, imgs)
    if (root / "dataset.json").exists():
        shutil.copyfile(root / "dataset.json", out / "dataset.json")
    return [v[0] for v in views]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("nerf_dir")
    p.add_argument("out_dir")
    p.add_argument("--text", action="store_true", help="write the model as text files (default: binary, as COLMAP does)")
    a = p.parse_args()
    names = convert(a.nerf_dir, a.out_dir, a.text)
    print("nerf_to_colmap: %d views (%d held out by --holdout 8) -> %s" % (len(names), (len(names) + 7) // 8, a.out_dir))


if __name__ == "__main__":
    main()
