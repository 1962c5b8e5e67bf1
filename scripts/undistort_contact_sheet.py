#!/usr/bin/python3
"""Contact sheet of the lens undistortion on real camera files (made outside CI).

    scripts/undistort_contact_sheet.py [--build build] [--cameras tests/data/fox/transforms.json]
                                       [--scale 0.25] [--views 4] [--out out/undistort_sheet.png]

The fox capture's photos are not in the repository (only its camera file,
tests/data/fox), so its photos are synthesised: each chosen camera looks at a
checkered sky (a lat-long map of squares with a colour ramp) rendered by ptir as a
pinhole with a margin at twice the size, pushed through the file's own OPENCV lens
(k1 k2 p1 p2; scripts/dataset/capture.py: the photo pixel's ray found by Newton's
method on COLMAP's formula) and box-filtered down: a distorted photo as that lens
would take it. The engine then reads the folder as any nerfstudio capture and
undistorts it (its cache); `ptir cameras` gives the undistorted pinhole cameras,
rendered directly as the reference.

Each row: distorted photo | undistorted by ptir | pinhole render of the same camera |
|difference| x 4. Prints the PSNR of each undistorted photo against its reference.
"""

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
from dataset import capture, layouts, png  # noqa: E402

SS = 2  # supersampling of the synthetic photos


def checker_sky(w=1024, h=512):
    u, v = np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h)
    sq = ((np.floor(u * 48) + np.floor(v * 24)) % 2)[..., None]
    ramp = np.stack([u, 0.5 + 0.5 * np.cos(2 * math.pi * u), v], -1)
    return (0.08 + 0.85 * sq * (0.35 + 0.65 * ramp)).astype(np.float32)


def render_frames(ptir, folder, frames, w, h):
    """Pinhole renders of frames (dicts with transform_matrix, fl_x, fl_y, cx, cy) at w x h."""
    (folder / "cams.json").write_text(json.dumps({"camera_angle_x": 1.0, "w": w, "h": h, "frames": frames}))
    # One tiny Gaussian far behind everything: the scene needs a field; the sky is what is seen.
    scene = ptir.scene_from_dict({"gaussians": [{"file": "g.ply"}], "environment": {"type": "latlong", "file": "sky.exr"},
                                  "cameras": [{"transforms": "cams.json"}]}, base_dir=str(folder))
    return [scene.render(i, spp=4, bounces=0)[..., :3] for i in range(len(frames))]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--build", default=str(ROOT / "build"))
    p.add_argument("--cameras", default=str(ROOT / "tests" / "data" / "fox" / "transforms.json"))
    p.add_argument("--scale", type=float, default=0.25)
    p.add_argument("--views", type=int, default=4)
    p.add_argument("--out", default=str(ROOT / "out" / "undistort_sheet.png"))
    a = p.parse_args()
    sys.path.insert(0, str(Path(a.build) / "python"))
    import ptir
    sys.path.insert(0, str(ROOT / "tests" / "python"))
    from ptir_testing import write_splat_ply

    meta = json.loads(Path(a.cameras).read_text())
    s = a.scale
    w, h = int(round(meta["w"] * s)), int(round(meta["h"] * s))
    fx, fy, cx, cy = meta["fl_x"] * s, meta["fl_y"] * s, meta["cx"] * s, meta["cy"] * s
    dist = [meta.get(k, 0.0) for k in ("k1", "k2", "p1", "p2")]
    picks = [meta["frames"][int(i)] for i in np.linspace(0, len(meta["frames"]) - 1, a.views)]
    work = Path(tempfile.mkdtemp(prefix="ptir_undistort_sheet_"))
    write_splat_ply(work / "g.ply", [[0.0, 0.0, -1e4]], [1e-3, 1e-3, 1e-3])
    ptir.write_image(str(work / "sky.exr"), checker_sky())

    # Distorted photos: a pinhole with a margin m at SS x, through the lens, cropped, box-filtered.
    m = int(0.15 * max(w, h))
    big = []
    for fr in picks:
        c2w = np.array(fr["transform_matrix"], np.float64)
        c2w[:3, :3] /= np.linalg.norm(c2w[:3, :3], axis=0)
        big.append({"file_path": Path(fr["file_path"]).stem, "transform_matrix": c2w.tolist(), "fl_x": SS * fx,
                    "fl_y": SS * fy, "cx": SS * (cx + m), "cy": SS * (cy + m)})
    renders = render_frames(ptir, work, big, SS * (w + 2 * m), SS * (h + 2 * m))
    cap = work / "capture"
    (cap / "images").mkdir(parents=True)
    lens = ("OPENCV", [SS * fx, SS * fy, SS * (cx + m), SS * (cy + m), *dist])
    photos = []
    for fr, img in zip(big, renders):
        d = capture.distort_image(png.srgb_encode(img), *lens)[SS * m:SS * (m + h), SS * m:SS * (m + w)]
        photo = capture.box_downsample(d, SS)
        photos.append(photo)
        png.write_png(cap / "images" / (fr["file_path"] + ".png"), png.to_8bit(photo))
    frames = [("images/%s.png" % fr["file_path"], fr["transform_matrix"]) for fr in big]
    layouts.write_nerfstudio(cap / "transforms.json", frames,
                             {"camera_model": "OPENCV", "fl_x": fx, "fl_y": fy, "cx": cx, "cy": cy, "w": w, "h": h,
                              "k1": dist[0], "k2": dist[1], "p1": dist[2], "p2": dist[3]})

    # The engine's undistortion, and its pinhole cameras rendered directly.
    subprocess.run([str(Path(a.build) / "bin" / "ptir"), "cameras", "--dataset", str(cap), "-o",
                    str(work / "undistorted.json")], check=True)
    und = json.loads((work / "undistorted.json").read_text())
    ref = render_frames(ptir, work, und["frames"], und["w"], und["h"])
    rows, lines = [], []
    for fr, photo, r in zip(und["frames"], photos, ref):
        got = np.clip(ptir.read_image(fr["file_path"], linear=False)[..., :3], 0, 1)
        want = png.srgb_encode(r)
        err = np.abs(got - want)
        psnr = 10 * math.log10(1.0 / max(np.mean(err ** 2), 1e-12))
        lines.append("%s: undistorted %dx%d of %dx%d, PSNR %.2f dB against the pinhole render" %
                     (fr["name"], und["w"], und["h"], w, h, psnr))
        pad = lambda x: np.pad(x, ((0, h - x.shape[0]), (0, w - x.shape[1]), (0, 0)))  # noqa: E731
        rows.append(np.concatenate([photo, pad(got), pad(want), pad(np.clip(4 * err, 0, 1))], 1))
    sheet = np.concatenate(rows, 0)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    png.write_png(a.out, png.to_8bit(sheet))
    print("\n".join(lines))
    print("wrote %s (rows: distorted photo | undistorted by ptir | pinhole render | |difference| x 4)" % a.out)


if __name__ == "__main__":
    main()
