#!/usr/bin/python3
"""The real-capture path against known materials (issue 51's ground truth; docs/captures.md,
"Synthetic captures: the same path against known materials").

    bench/bench_capture_truth.py [--members 02_facets,04_monkey_torus] [--res 128] [--iters 250]
        [--spp 4] [--geometry] [--out out/capture_truth] [--threads 0] [--json FILE]

1. The dataset maker (Cycles in Blender 3.4) makes a family member (bench/family_def.py) as a NeRF set
   (transparent film, ground truth on the test views) and, with --capture-room, the same training views
   photographed on a floor before two walls (scripts/dataset/room.py): JPEGs with EXIF, two at x0.5 and
   two at x2, a COLMAP text model, no masks.
2. The user's splat: the set's object splats with their radiance refitted to the room photos (`ptir fit
   --sh-only` on the photos with the object's true coverage as masks): a trained splat, cleaned of the
   floor and walls, as a user brings it.
3. `ptir optimize` with that splat (--fit-iters 0 unless --geometry adds a run with the geometry stage)
   in the variants that matter (VARIANTS), each scored by `ptir eval` on the NeRF set's test views
   (albedo: scale-aligned sRGB PSNR, per-channel scale ground truth / ours), by the capture stage's
   decision (subject, mask IoU against the true coverage, each photo's gain x EXIF against the true
   exposure) and by bench/bench_real_capture.py on the held-out photos (the object's pixels and the
   frame).
Prints a markdown table. A benchmark (minutes), never part of the tests; tests/blender/
test_capture_truth.py runs the same functions small.
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

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
BUILD = Path(os.environ.get("PTIR_BUILD_DIR", REPO / "build")).resolve()
CLI = BUILD / "bin" / "ptir"
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(BUILD / "python"))

import family_def  # noqa: E402
import make_family  # noqa: E402

# (key, what it is, dataset: "nerf" | "room" | "room_masked", extra optimize flags; {proxy}: the set's
# capture/room/true_room.json)
VARIANTS = [
    ("nerf", "masked NeRF set, transparent film (today's synthetic path: the reference)", "nerf", []),
    ("room_true_masks", "room photos with the object's true masks (no capture stage)", "room_masked", []),
    ("room", "room capture (default): coverage masks pick the patches, every pixel supervised, background starts the environment", "room", []),
    ("room_mask_loss", "room capture, --background-loss off (the loss on the coverage masks only)", "room",
     ["--background-loss", "off"]),
    ("room_fix_env", "room capture, --fix-env-seen", "room", ["--fix-env-seen"]),
    ("room_warm0", "room capture, --albedo-warmup 0", "room", ["--albedo-warmup", "0"]),
    ("room_tv3", "room capture, --lambda-tv 0.3", "room", ["--lambda-tv", "0.3"]),
    ("room_scene", "room capture, --subject scene (no mask)", "room", ["--subject", "scene"]),
    # A perfect floor-and-walls proxy (the true room as meshes with their true materials, --scene): what
    # building one could win at most.
    ("room_true_masks_proxy", "room photos, true masks, the true room as --scene", "room_masked", ["--scene", "{proxy}"]),
    ("room_proxy", "room capture (default) with the true room as --scene", "room", ["--scene", "{proxy}"]),
]


def run(cmd, log=None):
    t = time.time()
    with open(log, "w") if log else open(os.devnull, "w") as f:
        rc = subprocess.run([str(c) for c in cmd], stdout=f, stderr=subprocess.STDOUT).returncode
    if rc != 0:
        raise RuntimeError("exit %d: %s%s" % (rc, " ".join(str(c) for c in cmd), " (log %s)" % log if log else ""))
    return time.time() - t


def capture_member(name, res=128, train=16, test=6, spp=64):
    """The family member `name` as a capture set: Blender 3.4, no relight environments."""
    m = [x for x in family_def.members() if x["name"] == name]
    if not m:
        raise SystemExit("no family member %r" % name)
    return dict(m[0], name="%s_capture_%d" % (name, res), blender="3.4", res=res, train=train, test=test, spp=spp,
                relight_envs="", capture_room=True)


def make(member, out, threads=0):
    """The member's NeRF set (with capture/room/); returns its folder."""
    os.makedirs(out, exist_ok=True)
    folder, secs, made = make_family.make(member, out, threads)
    if made:
        print("made %s in %.0f s" % (folder, secs), flush=True)
    return folder


def masked_room(data, out):
    """The room photos with the object's true coverage as masks/ (links): what the user's trainer saw
    of the object, and the variant that knows the mask."""
    room, folder = Path(data) / "capture" / "room", Path(out)
    if not folder.exists():
        folder.mkdir(parents=True)
        for src, dst in (("images", "images"), ("sparse", "sparse"), ("true_masks", "masks"), ("dataset.json", "dataset.json")):
            os.symlink(room / src, folder / dst)
    return folder


def user_splat(data, work, iters=1500, threads=0):
    """The set's object splats with their SH radiance fitted to the room photos (geometry frozen)."""
    out = Path(work) / "user_splat"
    if not (out / "gaussians.ply").exists():
        masked = masked_room(data, Path(work) / "room_masked")
        secs = run([CLI, "fit", "--dataset", masked, "--gaussians", Path(data) / "gaussians.ply", "--out", out,
                    "--sh-only", "--iters", iters, "--threads", threads, "--force"], Path(work) / "user_splat.log")
        print("user splat: SH refit on the room photos in %.0f s" % secs, flush=True)
    return out / "gaussians.ply"


def dataset_of(kind, data, work):
    return {"nerf": Path(data), "room": Path(data) / "capture" / "room",
            "room_masked": masked_room(data, Path(work) / "room_masked")}[kind]


def optimize(dataset, splat, out, extra=(), iters=250, spp=4, fit_iters=0, seed=0, threads=0):
    cmd = [CLI, "optimize", "--dataset", dataset, "--gaussians", splat, "--out", out, "--iters", iters, "--spp", spp,
           "--seed", seed, "--threads", threads, "--force"] + (["--fit-iters", fit_iters] if fit_iters is not None else [])
    return run(cmd + list(extra), str(out) + ".log")


def evaluate(data, out, spp=16, threads=0):
    """`ptir eval` on the NeRF set's test views: its metrics.json."""
    run([CLI, "eval", "--dataset", data, "--result", out, "--spp", spp, "--aov-spp", 8, "--sheet-views", 0,
         "--threads", threads, "-q", "--force"])
    return json.loads((Path(out) / "eval" / "metrics.json").read_text())


def read_mask(path):
    import ptir
    return ptir.read_image(str(path), linear=False)[..., 0] > 0.5


def capture_decision(data, out):
    """What the capture stage decided against the truth: subject, mask IoU (mean over photos), and
    each photo's total scale (EXIF where applied x its gain, channel mean) relative to the median of
    the photos taken at exposure 1, against the true exposure. None when it did not run."""
    import ptir
    cal_file = Path(out) / "capture" / "calibration.json"
    if not cal_file.exists():
        return None
    cal = json.loads(cal_file.read_text())
    room = Path(data) / "capture" / "room"
    truth = json.loads((room / "exposures.json").read_text())["relative_exposure"]
    ds = ptir.load_dataset(str(room), split="all")
    exif = dict(zip(ds.view_names, ds.exposures)) if cal.get("exif_exposure", True) else {}
    total = {n: exif.get(n, 1.0) * float(np.mean(cal["views"].get(n, {}).get("gain", [1.0, 1.0, 1.0])))
             for n in truth}
    ref = float(np.median([total[n] for n in truth if truth[n] == 1.0]))
    err = {n: total[n] / ref / truth[n] - 1.0 for n in truth}
    ious = []
    mask_dir = Path(out) / "capture" / "masks"
    for n in truth:
        t = read_mask(room / "true_masks" / (n + ".png"))
        m = read_mask(mask_dir / (n + ".png")) if (mask_dir / (n + ".png")).exists() else np.ones_like(t)
        ious.append(float((t & m).sum()) / max(1.0, float((t | m).sum())))
    bracketed = [n for n in truth if truth[n] != 1.0]
    return {"subject": cal["subject"], "exif_applied": bool(cal.get("exif_exposure", True)),
            "mask_iou": float(np.mean(ious)), "gain_error": err,
            "gain_error_bracketed": max(abs(err[n]) for n in bracketed),
            "gain_error_all": max(abs(e) for e in err.values()),
            "relative": {n: total[n] / ref for n in bracketed}}


def held_out(data, out, splat, spp=16):
    """bench_real_capture.py on the room's held-out photos: mean PSNR on the object's pixels (the
    true coverage) and over the frame."""
    room = Path(data) / "capture" / "room"
    js = Path(str(out) + "_heldout.json")
    masks = Path(out) / "capture" / "masks"
    moved = None
    if masks.exists():  # score every variant on the same (true) object pixels
        moved = masks.with_name("masks_detected")
        masks.rename(moved)
    try:
        shutil.copytree(room / "true_masks", masks)
        run([sys.executable, HERE / "bench_real_capture.py", "--dataset", room, "--result", out, "--input", splat,
             "--spp", spp, "--json", js])
    finally:
        shutil.rmtree(masks, ignore_errors=True)
        if moved:
            moved.rename(masks)
    return json.loads(js.read_text())["mean"]


def run_variant(key, kind, extra, data, work, splat, a, fit_iters=0):
    """One `ptir optimize` run scored every way; its row."""
    out = Path(work) / (key if not a.seed else "seed%d_%s" % (a.seed, key))
    extra = [e.format(proxy=Path(data) / "capture" / "room" / "true_room.json") for e in extra]
    secs = optimize(dataset_of(kind, data, work), splat, out, extra, a.iters, a.spp, fit_iters, a.seed, a.threads)
    m = evaluate(data, out, a.eval_spp, a.threads)
    row = {"variant": key, "seconds": secs, "albedo_psnr": m["albedo_psnr"], "albedo_scale": m["albedo_scale"],
           "nvs_psnr": m["nvs_psnr"], "roughness_mse": m["roughness_mse"],
           "decision": capture_decision(data, out), "held_out": held_out(data, out, splat, a.eval_spp)}
    print(json.dumps(row), flush=True)
    return row


def gain_checks(data, work, splat, threads=0):
    """The capture stage's exposures alone (a 1-iteration run): with EXIF ignored (the per-photo gains
    must find the brackets themselves), and with the maker's splat, whose colour is its albedo and not
    the photos' radiance. {case: capture_decision}."""
    out = {}
    for key, ply, extra in (("gains_without_exif", splat, ["--ignore-exif"]),
                            ("gains_albedo_coloured_splat", Path(data) / "gaussians.ply", [])):
        o = Path(work) / key
        optimize(dataset_of("room", data, work), ply, o, extra, iters=1, spp=1, threads=threads)
        out[key] = capture_decision(data, o)
        print("%s: worst exposure error %.1f %% (x0.5/x2 photos %.1f %%), EXIF %s" % (
            key, 100 * out[key]["gain_error_all"], 100 * out[key]["gain_error_bracketed"],
            "applied" if out[key]["exif_applied"] else "not applied"), flush=True)
    return out


def table(rows):
    lines = ["| member | run | subject | mask IoU | gains x0.5/x2 (worst error) | albedo sRGB PSNR (dB) | "
             "scale GT/ours (R, G, B) | held-out object / frame (dB) |", "|---|---|---|---:|---:|---:|---|---:|"]
    for r in rows:
        if "checks" in r:
            continue
        d = r["decision"]
        lines.append("| %s | %s | %s | %s | %s | %.2f | %s | %.2f / %.2f |" % (
            r["member"], r["variant"], d["subject"] if d else "(masks given)", "%.3f" % d["mask_iou"] if d else "–",
            "%.1f %%" % (100 * d["gain_error_bracketed"]) if d else "–", r["albedo_psnr"],
            ", ".join("%.3f" % s for s in r["albedo_scale"]), r["held_out"]["object"], r["held_out"]["frame"]))
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    # The sizes: the set's resolution, the inversion's iterations and spp, the evaluation's spp, the
    # user splat's SH refit iterations, threads of Cycles and ptir (0: all).
    for flag, default in (("--res", 128), ("--iters", 250), ("--spp", 4), ("--eval-spp", 16), ("--seed", 0),
                          ("--user-iters", 1500), ("--threads", 0)):
        ap.add_argument(flag, type=int, default=default)
    ap.add_argument("--members", default="02_facets", help="comma-separated family members")
    ap.add_argument("--only", default="", help="comma-separated variants (default: all)")
    ap.add_argument("--geometry", action="store_true", help="also the default capture run with the geometry stage")
    ap.add_argument("--gain-checks", action="store_true",
                    help="also the exposures without EXIF and with an albedo-coloured splat")
    ap.add_argument("--out", default=str(REPO / "out" / "capture_truth"), help="sets and runs (kept between calls)")
    ap.add_argument("--json", help="also write the rows here")
    a = ap.parse_args()
    rows = []
    for name in a.members.split(","):
        member = capture_member(name, a.res)
        data = make(member, a.out, a.threads)
        work = Path(a.out) / (member["name"] + "_runs")
        splat = user_splat(data, work, a.user_iters, a.threads)
        for key, _, kind, extra in VARIANTS:
            if not a.only or key in a.only.split(","):
                rows.append(dict(run_variant(key, kind, extra, data, work, splat, a), member=name))
        if a.gain_checks:
            rows.append({"member": name, "variant": "gain_checks", "checks": gain_checks(data, work, splat, a.threads)})
        if a.geometry:  # the default capture run with the geometry stage at its default
            rows.append(dict(run_variant("room_geometry", "room", [], data, work, splat, a, fit_iters=None), member=name))
    print(table(rows))
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
