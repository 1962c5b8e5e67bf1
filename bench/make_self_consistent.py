#!/usr/bin/env python3
"""A self-consistent twin of a Cycles dataset: the same cameras, masks, test views
and light, but its training images rendered by PTIR itself from the true
materials (the dataset's oracle/gaussians.ply) under the training environment.

    bench/make_self_consistent.py --dataset out/sample_dataset --out out/sample_self [--build build] [--spp 256]

Inverting the twin instead of the original separates what the inversion loses
from what the forward model's mismatch with Cycles costs (docs/inversion.md):
on the twin the oracle's materials explain the training images exactly, up to
Monte Carlo noise. The twin links everything but the training images to the
original (test views, envmaps, oracle, the input PLY); each training image takes
its RGB from PTIR (--bounces, Cycles' box filter of the dataset) and its alpha
from the original, so the masks are the same.
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np
from PIL import Image

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dataset", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--build", default=os.path.join(ROOT, "build"))
    p.add_argument("--spp", type=int, default=256)
    p.add_argument("--bounces", type=int, default=None, help="default: the dataset's Cycles bounces")
    p.add_argument("--oracle", help="the field with the true materials (default: the dataset's oracle/gaussians.ply; "
                   "e.g. the fitted field with the materials carried over by bench/oracle_on_field.py)")
    a = p.parse_args()
    src, out = os.path.abspath(a.dataset), os.path.abspath(a.out)
    ptir = os.path.join(os.path.abspath(a.build), "bin", "ptir")
    try:
        meta = json.load(open(os.path.join(src, "dataset.json")))
        frames = json.load(open(os.path.join(src, "transforms_train.json")))["frames"]
    except (OSError, ValueError, KeyError) as e:
        sys.exit("make_self_consistent: %s is not a PTIR dataset (%s)" % (src, e))
    oracle = os.path.abspath(a.oracle) if a.oracle else os.path.join(src, "oracle", "gaussians.ply")
    if not os.path.exists(oracle):
        sys.exit("make_self_consistent: %s not found (the true materials)" % oracle)
    env = os.path.join(src, meta["envmaps"][meta["train_env"]])
    bounces = a.bounces if a.bounces is not None else int(meta.get("cycles", {}).get("bounces", 4))
    os.makedirs(out, exist_ok=True)
    train_dirs = {os.path.normpath(f["file_path"]).split(os.sep)[0] for f in frames}
    for name in os.listdir(src):
        link = os.path.join(out, name)
        if name not in train_dirs and not os.path.lexists(link):
            os.symlink(os.path.join(src, name), link)
    for i, f in enumerate(frames):
        rel = os.path.normpath(f["file_path"])
        target = os.path.join(out, rel + ".png")
        os.makedirs(os.path.dirname(target), exist_ok=True)
        rgb_png = os.path.join(os.path.dirname(target), "ptir_rgb.png")
        subprocess.run([ptir, "render", "--gaussians", oracle, "--cameras", os.path.join(src, "transforms_train.json"),
                        "--frame", str(i), "--env", env, "--spp", str(a.spp), "--bounces", str(bounces),
                        "--pixel-filter", "box", "--filter-width", "1", "--aov", "rgb", "-q", "-o", rgb_png], check=True)
        rgb = np.asarray(Image.open(rgb_png).convert("RGB"))
        alpha = np.asarray(Image.open(os.path.join(src, rel + ".png")).convert("RGBA"))[..., 3:4]
        tmp = target + ".tmp.png"
        Image.fromarray(np.concatenate([rgb, alpha], -1).astype(np.uint8), "RGBA").save(tmp)
        os.replace(tmp, target)
        os.remove(rgb_png)
        print("\r%d / %d training views" % (i + 1, len(frames)), end="", flush=True)
    print("\nwrote %s" % out)


if __name__ == "__main__":
    main()
