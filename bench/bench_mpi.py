#!/usr/bin/python3
"""Data-parallel optimisation over MPI: measured cost on this machine and a model to 16 nodes.

    bench/bench_mpi.py [--build build] [--res 128] [--spp 8] [--iters 6] [--repeat 2] [--counts 100000,1000000]

1. Iterations/s of `ptir optimize` on the 2 cores here, as 1 rank x 2 threads and as
   2 ranks x 1 thread (`mpirun -np 2`), at 100K Gaussians (bench_optimize.py's sphere +
   floor dataset, RES^2, SPP, 2 bounces; median s/iter of iterations 2..N from rank 0's
   log.csv: rank 0 waits for the slowest rank in the gradient sum; the best of --repeat
   runs of each, alternated, against the other users of the machine).
2. The collectives of one iteration, timed alone with 2 ranks (bench_allreduce): the
   gradient sum (5 floats per Gaussian + the 128x64 lat-long environment) at 100K and 1M
   Gaussians, and the gather of a view's images (RGBA + 5 material-map channels).
3. A model of N = 1..16 nodes (each node like this one: its compute time is the 1-rank
   x 2-thread s/iter, split evenly by the row bands, times the band imbalance measured
   in 1.), plus the collectives on a network: the rank-ordered reduce-scatter +
   allgather moves 2 (N-1)/N x 4G bytes per rank in 2 (N-1) messages, the image gather
   (N-1)/N x 36 P bytes in N-1 messages, with per-message latency a and bandwidth B:
       T(N) = T1 / N * imbalance + 2 (N-1) a + 8 G (N-1) / (N B) + (N-1) a + 36 P (N-1) / (N B).
   Networks: the measured shared-memory figure here (B fitted from 2.), 10 GbE
   (1.25 GB/s, 50 us) and 100 Gb/s InfiniBand (12.5 GB/s, 2 us).
A benchmark, not a test: the machine is shared, so compare within a run.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_optimize import make_dataset  # noqa: E402  (the same synthetic dataset)

ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
ENV_FLOATS = 128 * 64 * 3  # the default lat-long environment's texels


def run(cmd, timeout=3600):
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=timeout, env=ENV)
    if r.returncode != 0:
        sys.exit("bench_mpi: error: %s\n%s" % (" ".join(str(c) for c in cmd), r.stderr[-2000:]))
    return r


def s_per_iter(cli, ply, ds, out, ranks, threads, args):
    shutil.rmtree(out, ignore_errors=True)
    cmd = [cli, "optimize", "--dataset", ds, "--gaussians", ply, "--out", out, "--iters", args.iters, "--spp", args.spp,
           "--bounces", 2, "--threads", threads, "--checkpoint-every", 0, "-q", "--fit-iters", 0]
    if ranks > 1:
        cmd = ["mpirun", "-np", ranks, "--oversubscribe", "--bind-to", "none"] + cmd
    t0 = time.time()
    run(cmd)
    wall = time.time() - t0
    rows = [l.split(",") for l in (out / "log.csv").read_text().splitlines()[1:]]
    return float(np.median([float(r[6]) for r in rows[1:]])), wall


def collectives(build, ranks, floats, pixels):
    r = run(["mpirun", "-np", ranks, "--oversubscribe", "--bind-to", "none", build / "bin" / "bench_allreduce",
             floats, pixels, 10])
    return json.loads(r.stdout.strip().splitlines()[-1])


def model(t1, imbalance, g_floats, pixels, a, bw, n):
    compute = t1 / n * (imbalance if n > 1 else 1.0)
    reduce = 2 * (n - 1) * a + 8.0 * g_floats * (n - 1) / (n * bw)
    gather = (n - 1) * a + 36.0 * pixels * (n - 1) / (n * bw)
    return compute + reduce + gather, reduce + gather


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--spp", type=int, default=8)
    ap.add_argument("--iters", type=int, default=6)
    ap.add_argument("--repeat", type=int, default=2, help="runs of each layout (the best counts)")
    ap.add_argument("--counts", default="100000,1000000", help="Gaussian counts of the allreduce rows")
    ap.add_argument("--data", default=str(ROOT / "out" / "bench_optimize"))
    args = ap.parse_args()
    build = Path(args.build) if Path(args.build).is_absolute() else Path.cwd() / args.build
    cli = build / "bin" / "ptir"
    if not shutil.which("mpirun"):
        sys.exit("bench_mpi: mpirun not found (Debian: openmpi-bin)")
    if "MPI: none" in run([cli, "--version"]).stdout:
        sys.exit("bench_mpi: %s was built without MPI (install libopenmpi-dev, reconfigure with PTIR_WITH_MPI=AUTO)" % cli)
    if not (build / "bin" / "bench_allreduce").exists():
        sys.exit("bench_mpi: %s/bin/bench_allreduce missing (build the bench_allreduce target)" % build)
    root = Path(args.data)
    root.mkdir(parents=True, exist_ok=True)
    pixels = args.res * args.res

    n = 100000
    ply, ds = make_dataset(build, root, n, args.res)
    out = root / "mpi_out"
    runs = {1: [], 2: []}
    for _ in range(max(1, args.repeat)):
        runs[1].append(s_per_iter(cli, ply, ds, out, 1, 2, args))
        runs[2].append(s_per_iter(cli, ply, ds, out, 2, 1, args))
    one, one_wall = min(runs[1])
    two, two_wall = min(runs[2])
    print("## Iterations/s, %dK Gaussians, %dx%d, %d spp, 2 bounces (this machine: %d cores, shared)\n"
          % (n // 1000, args.res, args.res, args.spp, os.cpu_count()))
    print("| layout | s/iter | it/s | wall (%d iterations, with load) |" % args.iters)
    print("|---|---:|---:|---:|")
    print("| 1 rank x 2 threads | %.3f | %.2f | %.1f s |" % (one, 1 / one, one_wall))
    print("| 2 ranks x 1 thread | %.3f | %.2f | %.1f s |" % (two, 1 / two, two_wall))
    # 2 ranks on the same 2 cores: > 1 is the split's overhead (gathers, the loss on every rank,
    # band imbalance); below 1 is the machine's noise, so the model takes at least 1.
    measured_ratio = two / one
    imbalance = max(1.0, measured_ratio)

    print("\n## Collectives per iteration, 2 ranks (shared memory), median of 10\n")
    print("| Gaussians | gradient floats | allreduce | MB/s per rank (2 (N-1)/N x 4G / t) | image gather (%dx%d) |"
          % (args.res, args.res))
    print("|---:|---:|---:|---:|---:|")
    measured = {}
    for count in [int(c) for c in args.counts.split(",")]:
        floats = 5 * count + ENV_FLOATS
        c = collectives(build, 2, floats, pixels)
        measured[count] = c
        rate = 2 * 0.5 * 4 * floats / c["allreduce_s"] / 1e6
        print("| %dK | %d | %.2f ms | %.0f | %.2f ms |" % (count // 1000, floats, 1e3 * c["allreduce_s"], rate,
                                                         1e3 * c["gather_s"]))

    # Shared-memory bandwidth fitted from the largest measured allreduce (latency ignored).
    big = max(measured)
    floats_big = 5 * big + ENV_FLOATS
    shm_bw = 8.0 * floats_big * 0.5 / measured[big]["allreduce_s"]
    networks = [("shared memory (measured)", 1e-6, shm_bw), ("10 GbE", 50e-6, 1.25e9), ("100 Gb/s IB", 2e-6, 12.5e9)]
    print("\n## Model: s/iter on N nodes (each = this machine's 2 cores; compute %.3f s/iter at 100K, split "
          "overhead x%.2f: 2 ranks / 1 rank measured %.3f)\n" % (one, imbalance, measured_ratio))
    print("Compute per iteration scales with pixels x spp, not with the Gaussian count's gradient size; the 1M rows")
    print("take the 100K compute time to show the communication alone (a real 1M scene renders slower).\n")
    header = "| Gaussians | network | " + " | ".join("N=%d" % k for k in (1, 2, 4, 8, 16)) + " | comm at 16 | speed-up 16 |"
    print(header)
    print("|" + "---|" * 2 + "---:|" * 7)
    for count in sorted(measured):
        g = 5 * count + ENV_FLOATS
        for name, a, bw in networks:
            ts = [model(one, imbalance, g, pixels, a, bw, k) for k in (1, 2, 4, 8, 16)]
            print("| %dK | %s | %s | %.1f ms | %.1fx |" % (count // 1000, name, " | ".join("%.3f" % t for t, _ in ts),
                                                          1e3 * ts[-1][1], ts[0][0] / ts[-1][0]))


if __name__ == "__main__":
    main()
