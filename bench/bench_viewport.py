"""Live viewport latency: seconds from an edit to the first new pixels, and the bytes the add-on sends.

    /usr/bin/python3 bench/bench_viewport.py [--build build] [--samples 2] [--pixel-size 4] [--splats 1000000]

Runs tests/blender/viewport_check.py (Blender's GUI under Xvfb, Rendered shading with PTIR, camera
view of the 1280x800 window) on the Cornell splat sample (2,000 splats) and on a copy whose splat
object holds --splats splats (bench/make_million_splats.py), and prints a table per scene and edit:
first pixels (the quarter-resolution first pass), all samples, the requests and bytes sent, and
whether the scene was re-loaded. Targets (issue 13): <= 0.5 s after a light or material edit,
<= 1 s after a camera move, no full scene re-send on edits. Timings, never assertions.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def run(cmd, env, timeout=900):
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout)
    if r.returncode != 0:
        sys.exit("bench_viewport: %s failed:\n%s\n%s" % (cmd[:3], r.stdout[-3000:], r.stderr[-2000:]))
    return r.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=str(REPO / "build"))
    ap.add_argument("--samples", type=int, default=2)
    ap.add_argument("--pixel-size", type=int, default=4)
    ap.add_argument("--splats", type=int, default=1_000_000)
    a = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="ptir_bench_viewport_"))
    env = dict(os.environ, PTIR_CLI=str(Path(a.build) / "bin" / "ptir"), PTIR_TEST_REPO=str(REPO),
               BLENDER_USER_SCRIPTS=str(work / "user"), BLENDER_USER_CONFIG=str(work / "config"))
    sample = REPO / "sample_blends" / "cornell_splats.blend"
    big = work / "million.blend"
    run(["blender", "-b", "--factory-startup", "-noaudio", str(sample), "-P",
         str(REPO / "bench" / "make_million_splats.py"), "--", str(big), str(a.splats)], env)
    rows = []
    for label, blend in (("Cornell splats (2,000)", sample), ("Cornell, %s splats" % format(a.splats, ","), big)):
        out = work / Path(blend).stem
        out.mkdir()
        text = run(["xvfb-run", "-a", "-s", "-screen 0 1280x800x24", "blender", "--factory-startup", "-noaudio",
                    str(blend), "-P", str(REPO / "tests" / "blender" / "viewport_check.py"), "--", str(out),
                    "--samples", str(a.samples), "--pixel-size", str(a.pixel_size), "--no-kill"], env)
        line = next(l for l in text.splitlines() if l.startswith("VIEWPORT_CHECK: "))
        steps = json.loads(line[len("VIEWPORT_CHECK: "):])["steps"]
        for name, what in (("base", "first view (load)"), ("albedo", "splat albedo edit"),
                           ("lights", "light + world power"), ("camera", "camera move"),
                           ("move", "splat object moved")):
            s = steps[name]
            sent = ", ".join("%s %s B" % (k, format(v, ",")) for k, v in sorted(s["sent_bytes"].items()))
            rows.append((label, what, s["first_pixels_s"], s["done_s"], sent, s["loads"]))
    print("\nLive viewport (%d samples, pixel size %d, 1280x800 window, 2 cores)\n" % (a.samples, a.pixel_size))
    print("| scene | edit | first pixels (s) | %d samples (s) | sent | loads so far |" % a.samples)
    print("|---|---|---:|---:|---|---:|")
    for r in rows:
        print("| %s | %s | %.3f | %.2f | %s | %d |" % r)


if __name__ == "__main__":
    main()
