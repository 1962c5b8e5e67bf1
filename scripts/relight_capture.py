#!/usr/bin/env python3
"""A real capture made relightable, as a picture: one of its photos, then the recovered asset from
that photo's camera relit under two new environments on a mesh floor (README, issue 51).

    python3 scripts/relight_capture.py --dataset CAPTURE --result OUT --photo NAME --out DIR
                                       [--env A.exr --env B.exr] [--width 480] [--spp 128]

OUT is a finished `ptir optimize --dataset CAPTURE` result (gaussians.ply; OUT/capture/calibration.json
when the capture stage ran). NAME is one of the capture's photos (a held-out one: every 8th).
1. The capture's cameras, undistorted, as `ptir cameras` writes them (with the run's calibration).
2. Up is the cameras' mean up vector (an orbit's tilts cancel); the floor lies across it at the
   recovered splats' 1st opacity-weighted height percentile, with a grey sphere beside the object
   (scripts/relight_any_splat.py's props).
3. Panels, left to right: the photo as stored; the recovered asset on the floor under each new
   environment (`ptir relight`, 3 bounces), each exposed on its own (99th percentile at 0.9).
DIR/relight_capture.png (sRGB) and each panel's EXR beside it.
"""

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
from relight_any_splat import build_tools, floor_and_sphere, floor_height, new_environments, run  # noqa: E402


def mean_up(frames):
    """The cameras' mean up vector (NeRF/Blender camera-to-world: column 1 is the image's up)."""
    ups = np.array([np.asarray(f["transform_matrix"], float)[:3, 1] for f in frames])
    up = ups.mean(axis=0)
    n = np.linalg.norm(up)
    if n < 1e-6:
        sys.exit("relight_capture: error: the cameras' up vectors cancel out; no floor can be placed")
    return up / n


def splat_bounds(ptir, ply):
    """Centre and radius of the splats with opacity >= 0.05 (their 2nd-98th percentile box)."""
    field = ptir.load_gaussians(str(ply))
    p, w = np.asarray(field.position, float), np.asarray(field.opacity, float)
    p = p[w >= 0.05]
    lo, hi = np.percentile(p, 2.0, axis=0), np.percentile(p, 98.0, axis=0)
    return {"centre": ((lo + hi) / 2).tolist(), "radius": float(np.linalg.norm(hi - lo) / 2)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dataset", type=Path, required=True)
    ap.add_argument("--result", type=Path, required=True)
    ap.add_argument("--photo", required=True, help="the photo's name (without extension)")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--env", type=Path, action="append", help="lat-long environment (.exr/.hdr); give two")
    ap.add_argument("--build", type=Path, default=ROOT / "build")
    ap.add_argument("--width", type=int, default=480, help="panel width (the height follows the photo)")
    ap.add_argument("--spp", type=int, default=128)
    args = ap.parse_args()
    if not (args.result / "gaussians.ply").is_file():
        sys.exit("relight_capture: error: %s has no gaussians.ply (run ptir optimize --dataset first)" % args.result)
    cli, ptir = build_tools(args, "relight_capture")

    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    cams = out / "cameras.json"
    cmd = [cli, "cameras", "--dataset", args.dataset, "-o", cams, "--force"]
    calibration = args.result / "capture" / "calibration.json"
    if calibration.is_file():
        cmd += ["--calibration", calibration]
    run(cmd)
    doc = json.loads(cams.read_text())
    names = [Path(f["file_path"]).stem for f in doc["frames"]]
    if args.photo not in names:
        sys.exit("relight_capture: error: %s has no photo named %s" % (args.dataset, args.photo))
    frame = names.index(args.photo)
    photo_path = Path(doc["frames"][frame]["file_path"])
    if not photo_path.is_absolute():
        photo_path = (cams.parent / photo_path).resolve()
    photo = np.asarray(ptir.read_image(str(photo_path)), np.float32)[..., :3]
    height = int(round(args.width * photo.shape[0] / photo.shape[1]))

    envs = new_environments(ptir, out, args.env)

    ply = args.result / "gaussians.ply"
    up = mean_up(doc["frames"])
    bounds = splat_bounds(ptir, ply)
    right = np.asarray(doc["frames"][frame]["transform_matrix"], float)[:3, 0]
    props = out / "floor_and_sphere.ply"
    floor_and_sphere(bounds, up, floor_height(ptir, ply, up), props, right)
    print("relight_capture: up (%.3f, %.3f, %.3f) from the cameras, photo %s (frame %d)" % (tuple(up) + (args.photo, frame)),
          flush=True)

    panels = [photo]
    for k, env in enumerate(envs):
        d = out / ("relit_%d" % k)
        run([cli, "relight", "--result", args.result, "--cameras", cams, "--frame", frame, "--width", args.width,
             "--height", height, "--env", env, "--mesh", props, "--mesh-color", "0.6,0.6,0.6", "--mesh-roughness",
             "0.4", "--spp", args.spp, "--bounces", 3, "-o", d, "-q", "--force"])
        exrs = sorted(d.glob("*.exr"))
        if not exrs:
            sys.exit("relight_capture: error: ptir relight wrote no EXR into %s" % d)
        r = np.asarray(ptir.read_image(str(exrs[0])), np.float32)[..., :3]
        panels.append(r * (0.9 / max(float(np.percentile(r.mean(-1), 99.0)), 1e-6)))
    # The photo at the panels' size (nearest: a picture, not a measurement).
    ys = (np.arange(height) * photo.shape[0] / height).astype(int)
    xs = (np.arange(args.width) * photo.shape[1] / args.width).astype(int)
    panels[0] = photo[ys][:, xs]
    gap = np.ones((height, 4, 3), np.float32)
    sheet = np.concatenate(sum(([np.clip(p, 0.0, 1.0), gap] for p in panels), [])[:-1], axis=1)
    ptir.write_image(str(out / "relight_capture.png"), np.ascontiguousarray(sheet, np.float32))
    print("relight_capture: wrote %s (photo | relit under %s)" % (out / "relight_capture.png",
                                                                  " | ".join(e.stem for e in envs)))


if __name__ == "__main__":
    try:
        main()
    except subprocess.CalledProcessError as e:
        sys.exit("relight_capture: error: %s failed (exit %d)" % (e.cmd[0], e.returncode))
