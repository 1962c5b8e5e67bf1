#!/usr/bin/python3
"""A real capture at a phone's photo size: the time before the first iteration and whether
`--budget` holds, at the photos' own size and with every photo upscaled.

    bench/bench_capture_photo_size.py [--dataset ../shared/data/captures/plushdog] [--scale 4]
                                      [--budget 5m] [--build build] [--ptir EXE] [--work /tmp/ptir_photo_size]
                                      [--extra "..."]

The capture's photos (a COLMAP set) are upscaled `scale` times per side (Lanczos, EXIF
kept: the plush dog's 750 x 500 become 3000 x 2000, a phone's size) into WORK, beside
the same sparse model and splat. `ptir optimize --dataset ... --gaussians ... --budget B`
runs on both; its log lines are time-stamped as they arrive. The table: the working
size the log states, the seconds until the capture's analysis is done (its "capture: an
object ..." or "capture: a scene ..." line), whether the geometry stage ran or was skipped
(its share of the budget under what the analysis took), the whole run's seconds, the
inversion's iterations, and whether OUT/gaussians.ply was written. --ptir runs another build (the
previous release, say) for a before/after. docs/captures.md ("Photos as a phone takes
them") has the table this measured. A benchmark, never part of the tests; it needs
the capture (test data: ../shared/data, never copied into the project).
"""

import argparse
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def upscaled(dataset, work, scale):
    """The capture with every photo `scale` times larger (kept between calls)."""
    from PIL import Image  # PyPI's Pillow: benches may use it, the product does not
    out = work / ("x%d" % scale)
    if (out / "done").exists():
        return out
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(dataset / "sparse", out / "sparse")
    (out / "images").mkdir(parents=True)
    for f in sorted((dataset / "images").iterdir()):
        im = Image.open(f)
        exif = im.info.get("exif")
        big = im.resize((im.width * scale, im.height * scale), Image.LANCZOS)
        big.save(out / "images" / f.name, quality=92, **({"exif": exif} if exif else {}))
    (out / "done").write_text("")
    return out


def run(ptir, dataset, gaussians, out, budget, extra):
    """`ptir optimize` with its stderr time-stamped line by line."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = [ptir, "optimize", "--dataset", str(dataset), "--gaussians", str(gaussians), "--out", str(out),
           "--budget", budget] + extra
    t0 = time.time()
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    lines = [(time.time() - t0, line.rstrip()) for line in p.stderr]
    p.wait()
    total = time.time() - t0
    analysis = next((t for t, l in lines if re.match(r"capture: (an object|a scene)", l)), float("nan"))
    size = next((l.split(", read at ")[1].split(" ")[0] for _, l in lines if ", read at " in l), "as stored")
    its = [int(m.group(1)) for _, l in lines for m in [re.search(r"log\.csv \((\d+) iterations\)", l)] if m]
    error = next((l for _, l in lines if "error" in l), "")
    fit = "skipped" if any("geometry fit skipped" in l for _, l in lines) else \
        "ran" if (out / "fit").is_dir() else "none"
    return {"fit": fit, "size": size, "analysis": analysis, "total": total, "iterations": its[-1] if its else 0,
            "written": (out / "gaussians.ply").exists() and p.returncode == 0, "error": error}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dataset", default=str(REPO.parent / "shared" / "data" / "captures" / "plushdog"))
    ap.add_argument("--gaussians", default="", help="the user's splat (default: DATASET/point_cloud_29999_clean.ply)")
    ap.add_argument("--scale", type=int, default=4)
    ap.add_argument("--budget", default="5m")
    ap.add_argument("--build", default=str(REPO / "build"))
    ap.add_argument("--ptir", default="", help="the ptir executable (default: BUILD/bin/ptir)")
    ap.add_argument("--work", default="/tmp/ptir_photo_size")
    ap.add_argument("--extra", default="", help="more optimize flags, one string")
    a = ap.parse_args()
    dataset = Path(a.dataset)
    if not (dataset / "images").is_dir() or not (dataset / "sparse").is_dir():
        print("bench_capture_photo_size: %s is not a COLMAP capture (images/, sparse/): skipped" % dataset)
        return 0
    gaussians = Path(a.gaussians) if a.gaussians else dataset / "point_cloud_29999_clean.ply"
    ptir = a.ptir or str(Path(a.build) / "bin" / "ptir")
    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    rows = [("as stored", run(ptir, dataset, gaussians, work / "out_1", a.budget, a.extra.split()))]
    big = upscaled(dataset, work, a.scale)
    rows.append(("x%d per side" % a.scale, run(ptir, big, gaussians, work / ("out_%d" % a.scale), a.budget,
                                               a.extra.split())))
    print("| photos | working size | analysis done (s) | geometry stage | run (s, budget %s) | iterations | "
          "result written |" % a.budget)
    print("|---|---|---:|---|---:|---:|---|")
    for label, r in rows:
        print("| %s | %s | %.1f | %s | %.1f | %d | %s |" % (label, r["size"], r["analysis"], r["fit"], r["total"],
                                                         r["iterations"], "yes" if r["written"] else "no: " + r["error"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
