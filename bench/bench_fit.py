#!/usr/bin/python3
"""Geometry-stage cost: iterations per second of `ptir fit` at 100K and 1M
Gaussians, 256x256, one primary ray per pixel, and the ratio to a material
iteration (`ptir optimize`) on the same inputs.

    bench/bench_fit.py [--build build] [--threads 2] [--iters 6] [--counts 100000,1000000] [--res 256]

Inputs: bench_optimize.py's synthetic dataset (a sphere shell of flat Gaussians
over a floor, 2 views rendered by ptir). Per point: `ptir fit --no-densify` for
--iters iterations, medians over iterations 2..N of the wall time and its parts
(BVH build, render + loss, replay + Adam); then `ptir optimize` at its defaults
(32 spp, 2 bounces) and at 1 spp / 0 bounces, medians likewise. A benchmark,
not a test: the machine may be shared, compare within a run.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_optimize as bo  # noqa: E402  (dataset maker and the optimize runner)


def fit_point(cli, ply, ds, out, iters, threads):
    import subprocess
    cmd = [str(cli), "fit", "--dataset", str(ds), "--gaussians", str(ply), "--out", str(out), "--iters", str(iters),
           "--no-densify", "--checkpoint-every", "0", "--threads", str(threads), "-q", "--force"]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    lines = (out / "log.csv").read_text().splitlines()
    head = lines[0].split(",")
    rows = [{k: float(v) for k, v in zip(head, l.split(",")) if k != "view"} for l in lines[1:]]
    use = rows[1:] if len(rows) > 1 else rows
    return {k: float(np.median([r[k] for r in use])) for k in ("seconds", "build_s", "forward_s", "backward_s")}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--iters", type=int, default=6)
    ap.add_argument("--counts", default="100000,1000000")
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--data", default=str(HERE.parent / "out" / "bench_optimize"))
    args = ap.parse_args()
    build = Path(args.build) if Path(args.build).is_absolute() else Path.cwd() / args.build
    cli = build / "bin" / "ptir"
    root = Path(args.data)
    root.mkdir(parents=True, exist_ok=True)
    print("bench_fit: %d threads, %dx%d, 1 ray/pixel, %d iterations per point (medians exclude the first)"
          % (args.threads, args.res, args.res, args.iters))
    print("| Gaussians | fit s/iter | it/s | BVH build | render+loss | replay+Adam | optimize s/iter (32 spp, 2 b) "
          "| ratio | optimize s/iter (1 spp, 0 b) | ratio |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for n in [int(c) for c in args.counts.split(",")]:
        ply, ds = bo.make_dataset(build, root, n, args.res)
        f = fit_point(cli, ply, ds, root / ("fit_%d" % n), args.iters, args.threads)
        mats = []
        for spp, bounces in ((32, 2), (1, 0)):
            rows, _, _ = bo.run_point(cli, ply, ds, root / ("opt_%d_%d" % (n, spp)), args.iters, spp, bounces, args.threads)
            mats.append(bo.summarise(rows, args.res * args.res, spp, args.threads)["s_iter"])
        print("| %d | %.3f | %.2f | %.3f | %.3f | %.3f | %.3f | %.2f | %.3f | %.2f |"
              % (n, f["seconds"], 1.0 / f["seconds"], f["build_s"], f["forward_s"], f["backward_s"], mats[0],
                 f["seconds"] / mats[0], mats[1], f["seconds"] / mats[1]))
        sys.stdout.flush()


if __name__ == "__main__":
    main()
