#!/usr/bin/python3
"""`make bench`: every benchmark in one run, then the ratios side by side.

    bench/bench_all.py [--build build] [--threads N] [--quick]

Runs, one after the other on this machine (each prints its own table):
  bench_trace.py      Gaussian vs triangle ray rate (full AOV and traversal, 1 thread and all)
  bench_path.py       ours on the heterogeneous sample vs Cycles on its mesh twin (same spp/bounces/threads)
  bench_gradients     the inversion's primal + replay on that scene per thread count (bit-identical
                      gradients checked) and the memory/time model of the gradient reduction at 16/64 threads
  bench_optimize.py   `ptir optimize` at 100K Gaussians, alone and in a room of mesh walls, 1 thread
                      and N: s/iter, path samples/s, peak RSS
and ends with a summary of the ratios the speed issue tracks. A benchmark, not a
test: the machine may be shared, so compare numbers within one run.
"""

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run(label, cmd):
    print("\n==== %s: %s" % (label, " ".join(str(c) for c in cmd)), flush=True)
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    sys.stdout.write(p.stdout)
    if p.returncode != 0:
        sys.stdout.write(p.stderr[-3000:])
        print("bench_all: %s failed (exit %d)" % (label, p.returncode))
    return p.stdout if p.returncode == 0 else ""


def grab(pattern, text, default="n/a"):
    m = re.search(pattern, text, re.M)
    return m.group(1) if m else default


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--quick", action="store_true", help="fewer repeats and sweep points")
    args = ap.parse_args()
    build = Path(args.build).resolve()
    py = sys.executable
    b = ROOT / "bench"

    trace = run("trace", [py, b / "bench_trace.py", "--build", build] + (["--repeat", "2"] if args.quick else []))
    path = run("path", [py, b / "bench_path.py", "--build", build, "--threads", args.threads, "--quick"])
    scene = ROOT / "out" / "bench_path" / "hetero" / "scene.json"
    grads = run("gradients", [build / "bin" / "bench_gradients", scene, "--spp", 8, "--threads", 1, args.threads]) \
        if scene.exists() else ""
    opt = run("optimize", [py, b / "bench_optimize.py", "--build", build, "--only", "threads,walls", "--threads", args.threads,
                           "--iters", 3 if args.quick else 4])

    rows = [
        ("ours / Cycles render time, heterogeneous sample vs its mesh twin (<= 1.0)",
         grab(r"Gaussians \+ meshes ([0-9.]+), mesh-only", path)),
        ("Gaussian / triangle ray rate, full AOV, 1 thread (>= 1/3)",
         grab(r"best Gaussian/triangle throughput, 1 thread, full AOV: +([0-9.]+ \(1/[0-9.]+\))", trace)),
        ("Gaussian / triangle ray rate, traversal only, 1 thread",
         grab(r"best Gaussian/triangle throughput, 1 thread, traversal: +([0-9.]+ \(1/[0-9.]+\))", trace)),
    ]
    g_table = grads.split("reduction model")[0]  # the per-thread-count rows, not the model's
    g_lines = [l.split() for l in g_table.splitlines() if re.match(r"^ +\d+ +[0-9.]+ +[0-9.]+ +[0-9.]+ +[0-9.]+ +\d+", l)]
    if g_lines:
        one, last = g_lines[0], g_lines[-1]
        rows += [
            ("inversion M path samples/s (primal + replay), hetero sample, %s thread(s) / %s" % (one[0], last[0]),
             "%s / %s" % (one[4], last[4])),
            ("the same in CPU time / threads (what the passes cost on idle cores; the machine may be shared)",
             "%s / %s" % (one[14], last[14]) if len(last) > 14 else "n/a"),
            ("replay / primal, 1 thread (replay reading the primal's ray outcomes and walks)", one[5]),
            ("replay reading outcomes and walks / replay tracing them, 1 thread", "%.2f" % (float(one[2]) / float(one[3]))),
            ("walks kept for the replay, MB (% of samples)", "%s (%s %%)" % (one[15], one[16]) if len(one) > 16 else "n/a"),
            ("thread scaling of primal + replay, %s vs 1 thread (wall)" % last[0],
             "%.2f" % ((float(one[1]) + float(one[2])) / (float(last[1]) + float(last[2])))),
            ("gradients identical across thread counts", "yes" if "DIFFERENT" not in grads else "NO"),
        ]
    m = re.search(r"^ +64 +([0-9.]+) +([0-9.]+) +([0-9.]+)", grads, re.M)
    if m:
        rows.append(("gradient reduction at 64 threads (model): memory MB per-thread copies -> tiles",
                     "%s -> %s" % (m.group(1), m.group(3))))
    for sweep, t, msps, rss in re.findall(r"^(threads|walls) +\d+ +\d+\^2 +\d+ spp \d bnc +(\d+) thr .*?\| cpu/\d+ .*?, ([0-9.]+) Msps \| peak RSS +([0-9.]+) MB",
                                        opt, re.M):
        what = "100K Gaussians" if sweep == "threads" else "100K Gaussians in a room of mesh walls"
        rows.append(("ptir optimize %s, 256^2 8 spp, %s thread(s): CPU-time M samples/s, peak RSS MB" % (what, t),
                     "%s, %s" % (msps, rss)))
    print("\n==== summary (%d threads)\n" % args.threads)
    print("| ratio | value |\n|---|---:|")
    for k, v in rows:
        print("| %s | %s |" % (k, v))
    return 0


if __name__ == "__main__":
    sys.exit(main())
