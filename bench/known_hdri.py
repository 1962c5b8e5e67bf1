#!/usr/bin/env python3
"""What a known HDRI buys, handed over in the wrong orientation, exposure and colour (issue 52).

    bench/known_hdri.py --dataset out/sample_dataset [--gaussians PLY] [--build build] [--out out/known_hdri]
        [--iters 200] [--spp 4] [--yaw 100] [--exposure 2.3] [--tint 1.1,1.0,0.85] [--rows exact,auto,...]

The dataset's true training map (dataset.json's train_env) is turned by --yaw about the up axis
(whole texel columns: the yaw a World's Mapping node would need to undo it), scaled by --exposure
and tinted by --tint, then `ptir optimize` (geometry stage off) and `ptir eval` run once per row:
    exact      the true map, fixed (--env-init TRUE --fix-env --env-align yaw: it must stay at 0, its level kept)
    auto       the handed-over map, fixed, aligned (--env-align auto: yaw; on masked photos the level from
               short inversions at candidate levels)
    yaw        ... aligned in yaw only: the map's own level kept (what auto did on masked photos before)
    full       ... aligned with an exposure from the mean-albedo assumption (--env-align full)
    exact_full the true map through the same (what the assumption costs where the level was right)
    refine     ... aligned (auto), then learnt at a tenth of the rate (--env-refine)
    off        the handed-over map as given, fixed (--env-align off)
    learn      no map: the environment learnt (the default inversion)
    search     ... its level from short inversions whether the map is fixed or learnt (--env-align search)
    exact_search the true map through the search (what it costs where the level was right)
Prints a Markdown table (albedo PSNR and per-channel scale from `ptir eval`, the solved yaw and
scale) and writes it to OUT/known_hdri.md. Runs are reused when OUT/<row>/eval exists.
"""

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

ROWS = {
    "exact": ["--env-init", "{true}", "--fix-env", "--env-align", "yaw"],
    "auto": ["--env-init", "{handed}", "--fix-env"],
    "yaw": ["--env-init", "{handed}", "--fix-env", "--env-align", "yaw"],
    "full": ["--env-init", "{handed}", "--fix-env", "--env-align", "full"],
    "exact_full": ["--env-init", "{true}", "--fix-env", "--env-align", "full"],
    "refine": ["--env-init", "{handed}", "--env-refine"],
    "off": ["--env-init", "{handed}", "--fix-env", "--env-align", "off"],
    "learn": [],
    "search": ["--env-init", "{handed}", "--fix-env", "--env-align", "search"],
    "exact_search": ["--env-init", "{true}", "--fix-env", "--env-align", "search"],
}


def handed_over(ptir, true_env, path, yaw, exposure, tint):
    t = ptir.read_image(true_env)[:, :, :3]
    cols = int(round(yaw / 360.0 * t.shape[1]))
    m = np.roll(t, -cols, axis=1) * np.float32(exposure) * np.asarray(tint, np.float32)
    ptir.write_image(path, np.ascontiguousarray(m, np.float32))
    return 360.0 * cols / t.shape[1]


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--dataset", required=True)
    p.add_argument("--gaussians", help="the splats (default: DATASET/gaussians.ply)")
    p.add_argument("--build", default=os.path.join(ROOT, "build"))
    p.add_argument("--out", default=os.path.join(ROOT, "out", "known_hdri"))
    p.add_argument("--iters", type=int, default=200)
    p.add_argument("--spp", type=int, default=4)
    p.add_argument("--eval-spp", type=int, default=32)
    p.add_argument("--yaw", type=float, default=100.0)
    p.add_argument("--exposure", type=float, default=2.3)
    p.add_argument("--tint", default="1.1,1.0,0.85")
    p.add_argument("--rows", default=",".join(ROWS))
    p.add_argument("--threads", type=int, default=0)
    a = p.parse_args()
    sys.path.insert(0, os.path.join(a.build, "python"))
    import ptir

    cli = os.path.join(a.build, "bin", "ptir")
    meta = json.load(open(os.path.join(a.dataset, "dataset.json")))
    true_env = os.path.join(a.dataset, meta["envmaps"][meta["train_env"]])
    gaussians = a.gaussians or os.path.join(a.dataset, "gaussians.ply")
    os.makedirs(a.out, exist_ok=True)
    handed = os.path.join(a.out, "handed.exr")
    truth = handed_over(ptir, true_env, handed, a.yaw, a.exposure, [float(x) for x in a.tint.split(",")])
    lines = [f"handed over: turned {truth:.1f} deg, x{a.exposure}, tint {a.tint}; {a.iters} iterations x {a.spp} spp",
             "", "| row | albedo PSNR (dB) | albedo scale gt/ours | solved yaw | solved scale | min |",
             "|---|---|---|---|---|---|"]
    for row in a.rows.split(","):
        out = os.path.join(a.out, row)
        t0 = time.time()
        if not os.path.exists(os.path.join(out, "eval", "metrics.json")):
            extra = [x.format(true=true_env, handed=handed) for x in ROWS[row]]
            cmd = [cli, "optimize", "--dataset", a.dataset, "--gaussians", gaussians, "--fit-iters", "0", "--iters",
                   str(a.iters), "--spp", str(a.spp), "--out", out, "-q", "--force", *extra]
            if a.threads:
                cmd += ["--threads", str(a.threads)]
            subprocess.run(cmd, check=True)
            subprocess.run([cli, "eval", "--dataset", a.dataset, "--result", out, "--spp", str(a.eval_spp),
                            "--sheet-views", "0", "-q"], check=True)
        m = json.load(open(os.path.join(out, "eval", "metrics.json")))
        rec = json.load(open(os.path.join(out, "settings.json"))).get("env_align", {})
        yaw = f"{rec['yaw_deg']:.0f}" if rec else "-"
        scale = " / ".join(f"{s:.2f}" for s in rec["scale"]) if rec else "-"
        lines.append(f"| {row} | {m['albedo_psnr']:.2f} | {' / '.join(f'{s:.2f}' for s in m['albedo_scale'])} | "
                     f"{yaw} | {scale} | {(time.time() - t0) / 60:.1f} |")
        print(lines[-1], flush=True)
    open(os.path.join(a.out, "known_hdri.md"), "w").write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
