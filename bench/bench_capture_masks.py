#!/usr/bin/python3
"""A masked and an unmasked run on one synthetic capture, with numbers.

    bench/bench_capture_masks.py [--build build] [--out out/capture_bench] [--iters 300] [--spp 16]
                                 [--threads 0] [--res 100]

1. The dataset maker (Blender + Cycles, cached in OUT/dataset) renders the sample
   object (sample_blends/sample_object.blend) from 16 + 8 views with
   --capture-layouts: the same views as a COLMAP capture (OPENCV lens, distorted
   photos with the environment behind the object, masks/).
2. `ptir optimize` on the COLMAP folder twice: with its masks, and on a copy without
   masks/ (every pixel supervised: the photo's background teaches the environment).
   Hold-out 8 (the capture's every 8th photo is not trained on); lat-long 64x32
   environment for both, so only the masks differ.
3. `ptir eval` of each result on the NeRF-layout dataset's 8 test views (ground-truth
   albedo, object masks; none of them is among the capture's photos used for training
   unless the hold-out keeps it) and on the capture's own held-out photos (NVS of the
   whole frame, background included).
Prints a markdown table. A benchmark (minutes), never part of the tests.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run(cmd, **kw):
    print("$ " + " ".join(str(c) for c in cmd), flush=True)
    t = time.time()
    subprocess.run([str(c) for c in cmd], check=True, **kw)
    return time.time() - t


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--build", default=str(ROOT / "build"))
    p.add_argument("--out", default=str(ROOT / "out" / "capture_bench"))
    p.add_argument("--iters", type=int, default=300)
    p.add_argument("--spp", type=int, default=16)
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--res", type=int, default=100)
    a = p.parse_args()
    cli = Path(a.build) / "bin" / "ptir"
    out = Path(a.out)
    data = out / "dataset"
    if not (data / "capture" / "colmap_bin" / "sparse").exists():
        run(["blender", "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1", "-P",
             ROOT / "scripts" / "make_dataset.py", "--", "--out", data, "--blend", ROOT / "sample_blends" / "sample_object.blend",
             "--res", a.res, "--train", 16, "--test", 8, "--spp", 64, "--relight-envs", "", "--capture-layouts"])
    masked = data / "capture" / "colmap_bin"
    unmasked = out / "colmap_unmasked"
    if not unmasked.exists():
        unmasked.mkdir(parents=True)
        for sub in ("sparse", "images"):
            os.symlink(masked / sub, unmasked / sub)
    threads = ["--threads", a.threads] if a.threads > 0 else []
    rows = []
    for name, ds in (("masked", masked), ("unmasked", unmasked)):
        res = out / name
        secs = run([cli, "optimize", "--dataset", ds, "--gaussians", data / "gaussians.ply", "--out", res, "--iters", a.iters,
                    "--spp", a.spp, "--bounces", 2, "--env", "latlong", "--env-size", "64x32", "-q", "--force", "--fit-iters", 0, *threads])
        run([cli, "eval", "--dataset", data, "--result", res, "--spp", 64, "-q", "--force", *threads],
            stdout=subprocess.DEVNULL)
        m = json.loads((res / "eval" / "metrics.json").read_text())
        shutil.move(str(res / "eval"), str(res / "eval_synthetic"))
        run([cli, "eval", "--dataset", ds, "--result", res, "--spp", 64, "-q", "--force", *threads],
            stdout=subprocess.DEVNULL)
        c = json.loads((res / "eval" / "metrics.json").read_text())
        rows.append((name, m["albedo_psnr"], m["nvs_psnr"], m["nvs_ssim"], c["nvs_psnr"], c["views"], secs))
    print("\n%d iterations x %d spp x 2 bounces, %dx%d photos (OPENCV lens, undistorted), lat-long 64x32"
          % (a.iters, a.spp, a.res, a.res))
    print("| run | albedo PSNR (dB, 8 GT views) | NVS PSNR / SSIM (8 GT views, object) | NVS PSNR (held-out photos, full frame) | optimise s |")
    print("|---|---:|---:|---:|---:|")
    for n, alb, nvs, ssim, cap, views, secs in rows:
        print("| %s | %.2f | %.2f / %.3f | %.2f (%d views) | %.0f |" % (n, alb, nvs, ssim, cap, views, secs))


if __name__ == "__main__":
    sys.exit(main())
