#!/usr/bin/python3
"""Scale of a real-capture run: peak memory and time per iteration of `ptir optimize`
with millions of Gaussians at images_4-like photo sizes.

    bench/bench_capture_scale.py [--build build] [--gaussians 3000000] [--size 1237x822] [--views 8]
                                 [--iters 2] [--spp 4] [--threads 0] [--work /tmp/ptir_scale]
                                 [--masks] [--ptir EXE] [--estimate] [--extra "..."]

--masks writes RGBA photos whose alpha keeps the central disc (the object; masked
captures supervise it alone); --ptir runs another build (the previous release, say);
--estimate asks only for its estimate (`--estimate`: setup and s/iter, no iterations;
where one iteration would take many minutes); --extra passes more optimize flags.

The capture: N Gaussians of a full 3DGS PLY (SH degree 3, 62 float properties, as
trainers write them; 80 % on a sphere shell, 20 % scattered in a box around it, like
a scene's background), a COLMAP model (PINHOLE, `views` cameras on a ring; every 8th
held out) and stand-in photos of the given size (Mip-NeRF 360's images_4 is about
1237 x 822). `ptir optimize` runs under /usr/bin/time -v: the table shows its peak
RSS (target: <= 4 GB for 3M Gaussians), the estimate it prints before starting and
the measured seconds per iteration. A benchmark, never part of the tests.
"""

import argparse
import math
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
from dataset import layouts, png  # noqa: E402

SH_C0 = 0.28209479177387814


def write_scene_ply(path, n, rng):
    names = (["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"] + ["f_rest_%d" % i for i in range(45)]
             + ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"])
    rec = np.zeros(n, dtype=[(k, "<f4") for k in names])
    shell = int(0.8 * n)
    d = rng.normal(size=(shell, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pos = np.concatenate([d, rng.uniform(-4, 4, size=(n - shell, 3))])
    for i, c in enumerate("xyz"):
        rec[c] = pos[:, i]
    spacing = math.sqrt(4 * math.pi / shell)
    rec["scale_0"] = rec["scale_1"] = math.log(0.7 * spacing)
    rec["scale_2"] = math.log(0.05 * spacing)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    for i in range(4):
        rec["rot_%d" % i] = q[:, i]
    rec["opacity"] = 2.0
    for i in range(3):
        rec["f_dc_%d" % i] = (rng.uniform(0.2, 0.8, n) - 0.5) / SH_C0
    header = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
    header += "".join("property float %s\n" % k for k in names) + "end_header\n"
    with open(path, "wb") as f:
        f.write(header.encode())
        f.write(rec.tobytes())


def write_capture(root, views, w, h, rng, masks=False):
    f = 0.9 * w
    imgs = []
    for i in range(views):
        a = 2 * math.pi * i / views
        C = np.array([6 * math.cos(a), 6 * math.sin(a), 1.5])
        fwd = -C / np.linalg.norm(C)
        right = np.cross(fwd, [0, 0, 1.0])
        right /= np.linalg.norm(right)
        R = np.stack([right, np.cross(fwd, right), fwd])
        imgs.append((i + 1, layouts.quat_from_rotation(R), -R @ C, 1, "img_%03d.png" % i, np.zeros((0, 2)),
                     np.zeros(0, np.int64)))
    layouts.write_colmap_bin(root / "sparse" / "0", {1: ("PINHOLE", w, h, [f, f, w / 2, h / 2])}, imgs)
    (root / "images").mkdir(parents=True, exist_ok=True)
    base = png.to_8bit(rng.uniform(0.2, 0.8, size=(h, w, 3)))
    if masks:  # the object: a central disc of half the short side's radius
        yy, xx = np.mgrid[0:h, 0:w]
        inside = (xx - w / 2) ** 2 + (yy - h / 2) ** 2 <= (0.25 * min(w, h)) ** 2
        base = np.concatenate([base, np.where(inside, 255, 0).astype(base.dtype)[..., None]], axis=2)
    for _, _, _, _, name, _, _ in imgs:
        png.write_png(root / "images" / name, base)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--build", default=str(ROOT / "build"))
    p.add_argument("--gaussians", type=int, default=3_000_000)
    p.add_argument("--size", default="1237x822")
    p.add_argument("--views", type=int, default=8)
    p.add_argument("--iters", type=int, default=2)
    p.add_argument("--spp", type=int, default=4)
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--work", default="/tmp/ptir_scale")
    p.add_argument("--masks", action="store_true", help="RGBA photos: the alpha masks the object")
    p.add_argument("--ptir", help="the ptir to run (default: BUILD/bin/ptir)")
    p.add_argument("--estimate", action="store_true", help="the estimate only (no iterations)")
    p.add_argument("--extra", default="", help="more optimize flags")
    a = p.parse_args()
    w, h = (int(v) for v in a.size.lower().split("x"))
    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(1)
    ply = work / ("scene_%d.ply" % a.gaussians)
    if not ply.exists():
        write_scene_ply(ply, a.gaussians, rng)
    cap = work / ("capture_%dx%d_%d%s" % (w, h, a.views, "_masked" if a.masks else ""))
    if not (cap / "sparse").exists():
        write_capture(cap, a.views, w, h, rng, a.masks)
    out = work / "out"
    cmd = ["/usr/bin/time", "-v", a.ptir or str(Path(a.build) / "bin" / "ptir"), "optimize", "--dataset", str(cap), "--gaussians",
           str(ply), "--out", str(out), "--iters", str(a.iters), "--spp", str(a.spp), "--bounces", "2", "--force",
           "--checkpoint-every", "0", "--fit-iters", "0"]
    if a.threads > 0:
        cmd += ["--threads", str(a.threads)]
    cmd += a.extra.split() + (["--estimate"] if a.estimate else [])
    t0 = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.time() - t0
    if r.returncode != 0:
        sys.exit("ptir optimize failed:\n" + r.stderr[-3000:])
    err = r.stderr
    rss_gb = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", err).group(1)) / 2 ** 20
    est = re.search(r"estimated ([\d.]+) s/iter", err) or re.search(r'"s_per_iter": ([\d.]+)', r.stdout)
    cpu = re.search(r"User time \(seconds\): ([\d.]+)", err), re.search(r"System time \(seconds\): ([\d.]+)", err)
    print("process CPU s: %.1f" % (float(cpu[0].group(1)) + float(cpu[1].group(1))))
    print(r.stdout.strip())
    its = [float(x) for x in re.findall(r"\)\s+([\d.]+) s/iter", err)]
    print("\n".join(l for l in err.splitlines() if l.startswith(("optimize:", "iter "))))
    print("\n| Gaussians | photos | train views | spp x bounces | peak RSS (GB) | estimated s/iter | measured s/iter | "
          "wall s (load + %d iter + outputs) |" % a.iters)
    print("|---:|---|---:|---:|---:|---:|---:|---:|")
    print("| %d | %dx%d | %d | %d x 2 | %.2f | %s | %s | %.0f |" % (
        a.gaussians, w, h, a.views - (a.views + 7) // 8, a.spp, rss_gb, est.group(1) if est else "-",
        ", ".join("%.1f" % x for x in its) or "-", wall))


if __name__ == "__main__":
    main()
