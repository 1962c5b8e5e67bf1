#!/usr/bin/python3
"""The geometry stage's quality on a dataset with ground truth (issue 12): NVS
PSNR of the ray-traced SH render and normal MAE on the test views, for the
dataset's own splats (reference), the perturbed splats (before) and the fitted
ones (after).

    /usr/bin/python3 scripts/fit_quality.py --dataset DIR --out WORK [--iters 3000]
        [--build build] [--threads N] [--jitter 0.5] [--seed 0] [--fit-args "..."]
        [--normal-spp 16] [--json FILE]

DIR: a TensoIR-layout dataset from scripts/make_dataset.py (test_XXX/rgba.png and
normal.png, gaussians.ply). Perturbation: scripts/perturb_splats.py. Protocol as
`ptir eval` (docs/method.md §7): PSNR of sRGB display values composited over white,
whole image; normal MAE over the ground truth's foreground (alpha > 0.5). The
colour render is one ray per pixel centre (`ptir render --aov preview --spp 1`);
the normals are rendered as `ptir eval` renders them (16 jittered samples through
the dataset's pixel filter, dataset.json; Cycles' normal pass is a pixel average),
or with --normal-spp 1 at the pixel centres (the protocol of the first numbers).
Prints a table and (with --json) writes the numbers.
"""

import argparse
import json
import math
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
import perturb_splats  # noqa: E402


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def render(cli, gaussians, cameras, frame, aov, out, spp=1, pixel_filter=None):
    cmd = [str(cli), "render", "--gaussians", str(gaussians), "--cameras", str(cameras), "--frame", str(frame),
           "--aov", aov, "--spp", str(spp), "-o", str(out)]
    if spp > 1 and pixel_filter:
        cmd += ["--pixel-filter", pixel_filter["type"], "--filter-width", str(pixel_filter["width"])]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def dataset_filter(dataset):
    """The pixel filter the dataset was rendered with (dataset.json), else None (the renderer's default)."""
    try:
        return json.loads((dataset / "dataset.json").read_text())["cycles"]["pixel_filter"]
    except (OSError, KeyError, ValueError):
        return None


def over_white(rgba):
    """Associated linear RGBA as display values over white: the straight colour sRGB-encoded, blended by A."""
    a = np.clip(rgba[..., 3:4], 0, 1)
    straight = np.where(a > 0, rgba[..., :3] / np.maximum(a, 1e-6), 0.0)
    return srgb(straight) * a + (1 - a)


def score(ptir, cli, dataset, gaussians, work, normal_spp=16):
    """Mean NVS PSNR (dB) and normal MAE (degrees) over the test views."""
    cameras = dataset / "transforms_test.json"
    pixel_filter = dataset_filter(dataset)
    frames = json.loads(cameras.read_text())["frames"]
    psnrs, maes = [], []
    for i, fr in enumerate(frames):
        view = dataset / (fr["file_path"].lstrip("./") + ".png")
        gt = ptir.read_image(str(view), True)  # associated linear RGBA (docs/alpha.md)
        a = gt[..., 3:4]
        gt_disp = over_white(gt)
        render(cli, gaussians, cameras, i, "preview", work / "p.exr")
        render(cli, gaussians, cameras, i, "normal", work / "n.exr", normal_spp, pixel_filter)
        p = ptir.read_image(str(work / "p.exr"), True)
        pred_disp = over_white(p)  # the preview: associated linear RGBA, A = coverage
        mse = float(np.mean((pred_disp - gt_disp) ** 2))
        psnrs.append(10 * math.log10(1 / max(mse, 1e-10)))
        gtn_path = view.parent / "normal.png"
        if gtn_path.exists():
            gn = ptir.read_image(str(gtn_path), False)[..., :3] * 2 - 1
            pn = ptir.read_image(str(work / "n.exr"), False)[..., :3]
            fg = (a[..., 0] > 0.5) & (np.sum(gn * gn, -1) > 1e-12)
            lg, lp = np.linalg.norm(gn, axis=-1), np.linalg.norm(pn, axis=-1)
            cos = np.sum(gn * pn, -1) / np.maximum(lg * lp, 1e-12)
            ang = np.where(lp > 1e-6, np.degrees(np.arccos(np.clip(cos, -1, 1))), 90.0)
            maes.append(float(ang[fg].mean()))
    return float(np.mean(psnrs)), (float(np.mean(maes)) if maes else float("nan"))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dataset", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--iters", type=int, default=3000)
    p.add_argument("--build", default=os.environ.get("PTIR_BUILD_DIR", str(ROOT / "build")))
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--jitter", type=float, default=0.5)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--fit-args", default="")
    p.add_argument("--normal-spp", type=int, default=16)
    p.add_argument("--json")
    a = p.parse_args()
    build = Path(a.build)
    sys.path.insert(0, str(build / "python"))
    sys.path.insert(0, str(build / "lib"))
    import ptir  # noqa: E402
    cli = build / "bin" / "ptir"
    dataset, work = Path(a.dataset), Path(a.out)
    work.mkdir(parents=True, exist_ok=True)

    names, data, comments = perturb_splats.read_ply(str(dataset / "gaussians.ply"))
    perturbed = work / "perturbed.ply"
    perturb_splats.write_ply(str(perturbed), names, perturb_splats.perturb(names, data, a.jitter, a.seed), comments)
    t0 = time.time()
    cmd = [str(cli), "fit", "--dataset", str(dataset), "--gaussians", str(perturbed), "--out", str(work / "fit"),
           "--iters", str(a.iters), "-q", "--force"] + shlex.split(a.fit_args)
    if a.threads:
        cmd += ["--threads", str(a.threads)]
    subprocess.run(cmd, check=True)
    fit_s = time.time() - t0
    rows = {}
    for name, g in (("reference (dataset splats)", dataset / "gaussians.ply"), ("before (perturbed)", perturbed),
                    ("after (fitted)", work / "fit" / "gaussians.ply")):
        rows[name] = score(ptir, cli, dataset, g, work, a.normal_spp)
    print(f"geometry fit: {a.iters} iterations in {fit_s:.1f} s on {dataset}")
    print("| splats | NVS PSNR (dB) | normal MAE (deg) |\n|---|---:|---:|")
    for name, (psnr, mae) in rows.items():
        print(f"| {name} | {psnr:.2f} | {mae:.2f} |")
    if a.json:
        Path(a.json).write_text(json.dumps({"iterations": a.iters, "fit_seconds": fit_s,
                                            "rows": {k: {"nvs_psnr": v[0], "normal_mae_deg": v[1]}
                                                     for k, v in rows.items()}}, indent=1))


if __name__ == "__main__":
    main()
