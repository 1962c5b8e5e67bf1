#!/usr/bin/python3
"""The same masked data as a NeRF set and as a COLMAP capture, at `ptir optimize`'s
defaults (issue 38: "the defaults serve captures as well as synthetic sets").

    bench/bench_capture_vs_nerf.py --dataset out/tex128 [--out out/capture_vs_nerf] [--build build]
        [--previous /work/baseline-8a51f3d/bin/ptir] [--bare] [--extra "--iters 400"] [--eval-spp 32]

1. scripts/nerf_to_colmap.py writes the set (scripts/make_dataset.py's, e.g. --textured
   --res 128) as a COLMAP capture: one PINHOLE camera, the same RGB, poses and masks
   (alpha), its dataset.json; the default --holdout 8 keeps exactly the set's training views.
   --bare: also the capture without dataset.json (a capture that records nothing: ptir's
   defaults for the pixel filter and the surface model).
2. `ptir optimize` on each at the defaults (--extra is added to every run, e.g. a shorter
   --iters; the same seed); --previous: the capture with that binary too (the "before").
3. `ptir eval` of every result against the NeRF set's ground truth (its relight
   environments), and OUT/<run>/settings.json compared entry by entry with the NeRF run's.
Prints a markdown table. Runs are reused while their command is the same. Minutes to
hours: a benchmark, never part of the tests (tests/python/test_capture_defaults.py is).
"""

import argparse
import json
import shlex
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
import nerf_to_colmap  # noqa: E402

INPUT_ENTRIES = {"layout", "views_hash", "geometry_hash"}  # name the inputs, not settings


def run_once(cmd, folder, log):
    """Runs cmd unless folder/command.json records the same finished command; returns wall s."""
    rec = folder / "command.json"
    text = [str(c) for c in cmd]
    if rec.exists() and json.loads(rec.read_text()).get("command") == text:
        return json.loads(rec.read_text())["wall_s"]
    folder.mkdir(parents=True, exist_ok=True)
    print("$ " + " ".join(text), flush=True)
    t = time.time()
    with open(log, "w") as f:
        if subprocess.run(text, stdout=f, stderr=subprocess.STDOUT).returncode != 0:
            sys.exit("bench_capture_vs_nerf: failed, see %s" % log)
    wall = time.time() - t
    rec.write_text(json.dumps({"command": text, "wall_s": wall}))
    return wall


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dataset", required=True, help="a NeRF-layout set of scripts/make_dataset.py")
    p.add_argument("--out", default=str(ROOT / "out" / "capture_vs_nerf"))
    p.add_argument("--build", default=str(ROOT / "build"))
    p.add_argument("--previous", default="", help="another ptir binary: the capture with it too")
    p.add_argument("--bare", action="store_true", help="also the capture without the set's dataset.json")
    p.add_argument("--extra", default="", help="flags added to every optimize (e.g. \"--iters 400\")")
    p.add_argument("--eval-spp", type=int, default=32)
    p.add_argument("--nice", type=int, default=10)
    a = p.parse_args()
    data, out = Path(a.dataset).resolve(), Path(a.out).resolve()
    cli = str(Path(a.build) / "bin" / "ptir")
    colmap, bare = out / "colmap", out / "colmap_bare"
    if not (colmap / "sparse").exists():
        nerf_to_colmap.convert(data, colmap)
    if a.bare and not bare.exists():
        bare.mkdir(parents=True)
        for sub in ("sparse", "images", "masks"):
            (bare / sub).symlink_to(colmap / sub)
    runs = [("NeRF set", cli, data), ("COLMAP capture", cli, colmap)]
    if a.bare:
        runs.append(("COLMAP capture, no dataset.json", cli, bare))
    if a.previous:
        runs.append(("COLMAP capture, previous binary", a.previous, colmap))
    meta = json.loads((data / "dataset.json").read_text())
    relight = [f for n in meta.get("relight_envs", []) for f in ("--relight", "%s=%s" % (n, data / meta["envmaps"][n]))]
    rows, ref = [], None
    for i, (label, exe, ds) in enumerate(runs):
        folder = out / ("run_%d" % i)
        res = folder / "result"
        wall = run_once(["nice", "-n", a.nice, exe, "optimize", "--dataset", ds, "--gaussians", data / "gaussians.ply",
                         "--out", res, "-q", "--force", *shlex.split(a.extra)], folder, folder / "optimize.log")
        run_once(["nice", "-n", a.nice, cli, "eval", "--dataset", data, "--result", res, "--spp", a.eval_spp, "-q",
                  "--force", "--sheet-views", "0", *relight], folder / "eval_run", folder / "eval.log")
        m = json.loads((res / "eval" / "metrics.json").read_text())
        s = json.loads((res / "settings.json").read_text()) if (res / "settings.json").exists() else None
        ref = ref or s
        if i == 0:
            differ = "(the reference)"
        elif s is None:
            differ = "(no settings.json: a binary from before it)"
        else:
            keys = sorted(k for k in set(s) | set(ref) if k not in INPUT_ENTRIES and s.get(k) != ref.get(k))
            differ = "; ".join("%s %s" % (k, s.get(k)) for k in keys) or "none"
        rel = [v["psnr"] for v in m.get("relight", {}).values()]
        rows.append((label, m["albedo_psnr"], m.get("albedo_psnr_linear"), sum(rel) / len(rel) if rel else float("nan"),
                     m["nvs_psnr"], wall, differ))
    print("\n%s, extra flags: %s" % (data.name, a.extra or "none"))
    print("| run | albedo fg sRGB / linear (dB) | relight (dB) | NVS (dB) | optimise wall min | settings that differ from the NeRF run's |")
    print("|---|---:|---:|---:|---:|---|")
    for label, alb, lin, rl, nvs, wall, differ in rows:
        print("| %s | %.2f / %.2f | %.2f | %.2f | %.1f | %s |" % (label, alb, lin if lin is not None else float("nan"), rl,
                                                                  nvs, wall / 60, differ))


if __name__ == "__main__":
    sys.exit(main())
