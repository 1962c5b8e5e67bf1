#!/usr/bin/env python3
"""A recovered asset against a real capture's held-out photos (issue 51's protocol).

  bench/bench_real_capture.py --dataset CAPTURE --result OUT [--input IN.ply] [--spp 32] [--sheet sheet.png]

For every held-out photo (every 8th, as `ptir optimize` holds them out) it renders the
recovered asset (OUT/gaussians.ply) under its recovered light (OUT/env.exr, seen behind
it) from the photo's camera with `ptir render`, and compares in sRGB with the photo as
stored (JPEG), on
  - the object's pixels: the input splat's coverage > 0.5 (OUT/capture/masks, or the
    --input splat's opacity rendered), and
  - the whole frame,
once as rendered, once with the render scaled by the photo's EXIF exposure relative
to the capture's median (as `ptir cameras` reports it) and once by the photo's own gain
against the capture's consensus (its white balance and exposure, OUT/capture/calibration.json).
Prints a table (per photo and the mean) and writes it as JSON (--json); --sheet: photo |
recovered | albedo (the recovered base colour seen from the photo's camera, the albedo AOV) |
|error| x 4 rows.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
BUILD = Path(os.environ.get("PTIR_BUILD_DIR", REPO / "build"))
sys.path.insert(0, str(BUILD / "python"))
import ptir  # noqa: E402


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def psnr(a, b, m=None):
    d = (a - b) ** 2
    if m is not None:
        d = d[m]
    return float(-10 * np.log10(max(float(np.mean(d)), 1e-12)))


def with_meshes(scene_file, gaussians, env, camera, spp):
    """The recovered splats with the scene file's meshes (e.g. a floor proxy) under the recovered light."""
    scene = json.loads(Path(scene_file).read_text())
    scene = {"version": 1, "gaussians": [{"file": str(Path(gaussians).resolve())}],
             "meshes": scene.get("meshes", []), "lights": scene.get("lights", []),
             "environment": {"type": "latlong", "file": str(Path(env).resolve())}}
    return ptir.scene_from_dict(scene, base_dir=str(Path(scene_file).resolve().parent)).render(camera, spp=spp)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--result", required=True)
    ap.add_argument("--input", help="the input splat (its coverage: the object's pixels) when OUT/capture/masks is absent")
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--undistort-cache", default="")
    ap.add_argument("--json")
    ap.add_argument("--sheet")
    ap.add_argument("--gaussians", help="render these instead of RESULT/gaussians.ply")
    ap.add_argument("--scene", help="a scene file whose meshes (a floor proxy) take part in the recovered asset's render "
                    "(OUT/scene.json when the run had one)")
    ap.add_argument("--radiance", action="store_true",
                    help="score the splats' own radiance (the preview AOV: a geometry-frozen SH refit, the "
                         "reference of what the geometry can show) instead of the recovered asset's render")
    a = ap.parse_args()
    cli = str(BUILD / "bin" / "ptir")
    res = Path(a.result)
    scene_file = a.scene or (str(res / "scene.json") if (res / "scene.json").exists() else None)
    calibration = res / "capture" / "calibration.json"
    gains = json.loads(calibration.read_text()).get("views", {}) if calibration.exists() else {}
    test = ptir.load_dataset(a.dataset, split="test", undistort_cache=a.undistort_cache)
    raw = ptir.load_dataset(a.dataset, split="test", undistort_cache=a.undistort_cache, exif_exposure=False)
    with tempfile.TemporaryDirectory() as tmp:
        cams = Path(tmp) / "cams.json"
        subprocess.run([cli, "cameras", "--dataset", a.dataset, "--split", "test", "-o", str(cams)]
                       + (["--undistort-cache", a.undistort_cache] if a.undistort_cache else []),
                       check=True, capture_output=True)
        cover = None if not a.input else ptir.Scene(ptir.load_gaussians(a.input))
        rows, sheet = [], []
        for i, name in enumerate(test.view_names):
            out = Path(tmp) / ("%s.exr" % name)
            look = ["--aov", "preview", "--spp", "1"] if a.radiance else \
                ["--env", str(res / "env.exr"), "--aov", "rgb", "--spp", str(a.spp)]
            if scene_file and not a.radiance:
                r = with_meshes(scene_file, a.gaussians or str(res / "gaussians.ply"), str(res / "env.exr"),
                                test.cameras[i], a.spp)
            else:
                subprocess.run([cli, "render", "--gaussians", a.gaussians or str(res / "gaussians.ply"), "--cameras",
                                str(cams), "--frame", str(i), "-o", str(out), "-q"] + look, check=True)
                r = ptir.read_image(str(out))
            rgb, alpha = r[..., :3], r[..., 3] if r.shape[2] > 3 else np.ones(r.shape[:2])
            photo = raw.target(i)[0]
            mask_file = res / "capture" / "masks" / (name + ".png")
            if mask_file.exists():
                m = ptir.read_image(str(mask_file), linear=False)[..., 0] > 0.5
            else:
                m = cover.render_aov(test.cameras[i], "opacity")[..., 0] > 0.5
            e = test.exposures[i]
            row = {"view": name, "exposure": e}
            # The photo's own white balance and exposure against the capture's consensus, where the
            # capture stage measured it from the input splat (OUT/capture/calibration.json): what a
            # camera's auto white balance leaves that no asset can know.
            g = np.asarray(gains.get(name, {}).get("gain", [1.0, 1.0, 1.0]), np.float32)
            for tag, k in (("", 1.0), ("_exif", e), ("_gain", g)):
                shown = srgb(rgb * k)
                row["object" + tag] = psnr(shown, srgb(photo), m)
                row["frame" + tag] = psnr(shown, srgb(photo))
            rows.append(row)
            if a.sheet:
                err = np.abs(srgb(rgb) - srgb(photo)).mean(axis=2, keepdims=True) * 4
                panels = [srgb(photo), srgb(rgb)]
                if not a.radiance:  # the albedo AOV: one fabric should be one colour
                    aov = Path(tmp) / ("%s_albedo.exr" % name)
                    subprocess.run([cli, "render", "--gaussians", a.gaussians or str(res / "gaussians.ply"), "--cameras",
                                    str(cams), "--frame", str(i), "-o", str(aov), "-q", "--aov", "albedo"], check=True)
                    alb = ptir.read_image(str(aov))
                    panels.append(srgb(alb[..., :3]))  # associated with its coverage (EXR's rule): black outside
                panels.append(np.repeat(np.clip(err, 0, 1), 3, 2))
                sheet.append(np.concatenate(panels, axis=1))
            print("%-10s exposure %.3f  object %.2f dB (EXIF-scaled %.2f, gain-scaled %.2f)  frame %.2f dB (EXIF-scaled "
                  "%.2f, gain-scaled %.2f)  coverage %.2f" % (name, e, row["object"], row["object_exif"], row["object_gain"],
                                                              row["frame"], row["frame_exif"], row["frame_gain"],
                                                              alpha.mean()), flush=True)
    keys = ("object", "object_exif", "object_gain", "frame", "frame_exif", "frame_gain")
    mean = {k: float(np.mean([r[k] for r in rows])) for k in keys}
    print("mean       object %.2f dB (EXIF-scaled %.2f, gain-scaled %.2f)  frame %.2f dB (EXIF-scaled %.2f, gain-scaled %.2f)"
          % tuple(mean[k] for k in keys))
    if a.json:
        Path(a.json).write_text(json.dumps({"views": rows, "mean": mean}, indent=1) + "\n")
    if a.sheet:
        img = np.concatenate(sheet[::max(1, len(sheet) // 4)][:4], axis=0)
        ptir.write_image(a.sheet, img.astype(np.float32), colour=False)


if __name__ == "__main__":
    main()
