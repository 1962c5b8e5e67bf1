#!/usr/bin/python3
"""Gaussian vs triangle ray-tracing throughput on the ≥100K-Gaussian sample.

    bench/bench_trace.py [--build build] [--subdiv 4] [--size 256] [--zoom 2] [--repeat 5]
                         [--variants render_aov aov1x1 aov4x4 trav1x1 trav4x4 ...]

Makes out/bench/ with Blender (scripts/make_sample_splat.py --subdiv 4, ~130K
Gaussians) when it is missing, then runs BUILD/bin/bench_trace, which prints the
table (k = 8, 16, 32; one thread and all threads; render_aov, its per-pixel work
one ray at a time and in packets of pixel blocks, the traversal alone) and the
best Gaussian/triangle throughput ratios. A benchmark, not a test: the machine is
shared, so compare the ratios within one run, not absolute rays/s (one-thread
rows are timed in CPU time, all-thread rows in wall time).
"""

import argparse
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def make_sample(out, subdiv):
    blender = shutil.which("blender")
    if blender is None:
        sys.exit("bench_trace: error: blender not found (needed once to make %s)" % out)
    print("bench_trace: making the benchmark sample in %s (Blender, --subdiv %d)" % (out, subdiv), flush=True)
    t0 = time.time()
    r = subprocess.run([blender, "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1",
                        "-P", str(ROOT / "scripts" / "make_sample_splat.py"), "--",
                        "--out", str(out), "--subdiv", str(subdiv)], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("bench_trace: error: sample generation failed:\n" + r.stdout[-2000:] + r.stderr[-2000:])
    for line in r.stdout.splitlines():
        if line.startswith("make_sample_splat"):
            print(line)
    print("bench_trace: sample made in %.1f s" % (time.time() - t0))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--build", default="build", help="build folder (holds bin/bench_trace)")
    p.add_argument("--subdiv", type=int, default=4, help="sample subdivision level (4: ~130K Gaussians)")
    p.add_argument("--size", type=int, default=256, help="image width and height")
    p.add_argument("--zoom", type=float, default=2.0, help="narrow the view so the object fills most rays")
    p.add_argument("--repeat", type=int, default=5, help="timed runs per measurement")
    p.add_argument("--frame", type=int, default=0)
    p.add_argument("--variants", nargs="+", help="bench_trace variants (default: its own list)")
    args = p.parse_args()

    build = Path(args.build)
    if not build.is_absolute():
        build = Path.cwd() / build
    exe = build / "bin" / "bench_trace"
    if not exe.exists():
        sys.exit("bench_trace: error: %s not found: build it (the top-level CMakeLists.txt must have "
                 "add_subdirectory(bench)), e.g. 'make build'" % exe)

    sample = ROOT / "out" / "bench" if args.subdiv == 4 else ROOT / "out" / ("bench_subdiv%d" % args.subdiv)
    files = [sample / "gaussians.ply", sample / "transforms_test.json"]
    if not all(f.exists() and f.stat().st_size > 0 for f in files):
        make_sample(sample, args.subdiv)

    cmd = [str(exe), "--gaussians", str(files[0]), "--cameras", str(files[1]), "--frame", str(args.frame),
           "--size", str(args.size), "--zoom", str(args.zoom), "--repeat", str(args.repeat), "--k", "8", "16", "32"]
    if args.variants:
        cmd += ["--variants"] + args.variants
    sys.stdout.flush()
    return subprocess.run(cmd).returncode


if __name__ == "__main__":
    sys.exit(main())
