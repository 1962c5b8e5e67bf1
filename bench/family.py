"""The family bench (docs/family.md): `ptir optimize` on every member of a half of the family at a chosen
budget, scored by `ptir eval`, each number beside its oracle (the true materials on the same splats, the
dataset's oracle/), with the contact sheets of the worst three scenes gathered.

    python3 bench/family.py [--half tuning|heldout|all] [--iters N --spp N | --defaults]
                            [--tag NAME] [--extra "--flag value ..."] [--only NAME,...]
                            [--family out/family] [--runs out/family_runs] [--eval-spp 32] [--threads N]
                            [--fit-iters 1500]

Make the sets first (bench/make_family.py). The geometry stage (`ptir fit`, --fit-iters, default
optimize's 1500, seed 0) runs once per scene into RUNS/_fit<N>/<name>/ and every variant starts from it
with the field's bounce light, exactly as `ptir optimize` runs it after its own fit stage; --fit-iters 0
starts from the set's splats with path-traced bounce light (optimize --fit-iters 0). A run whose
OUT/eval/metrics.json exists is kept (--force reruns). Prints one row per scene, then mean and worst
per column, and writes RUNS/<tag>/summary.json and RUNS/<tag>/worst/ (the worst three's sheets).
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
import family_def  # noqa: E402

CLI = Path(os.environ.get("PTIR_BUILD_DIR", REPO / "build")) / "bin" / "ptir"
FIT_ITERS = 1500  # ptir optimize's --fit-iters default


def run(cmd, log):
    t0 = time.time()
    with open(log, "a") as f:
        f.write("$ " + " ".join(map(str, cmd)) + "\n")
        f.flush()
        rc = subprocess.run([str(c) for c in cmd], stdout=f, stderr=subprocess.STDOUT).returncode
    if rc != 0:
        raise RuntimeError("%s failed (exit %d): see %s" % (cmd[1], rc, log))
    return time.time() - t0


def relight_args(data):
    meta = json.load(open(data / "dataset.json"))
    return [a for env in meta.get("relight_envs", []) for a in ("--relight", "%s=%s" % (env, data / "envmaps" / (env + ".exr")))]


def eval_cmd(data, result, spp, threads):
    return [CLI, "eval", "--dataset", data, "--result", result, "--spp", spp, "-q", "--threads", threads] + relight_args(data)


def oracle_metrics(data, spp, threads, log):
    """The oracle's scores (true materials and light on the same splats), cached in the set's oracle/eval."""
    m = data / "oracle" / "eval" / "metrics.json"
    if not m.exists() or json.load(open(m))["settings"]["spp"] != spp or (relight_args(data) and not json.load(open(m))["relight"]):
        run(eval_cmd(data, data / "oracle", spp, threads), log)
    return json.load(open(m))


def fitted(data, runs, name, iters, threads, log):
    """The geometry stage once per scene (what optimize's fit stage makes at --fit-iters iters)."""
    out = runs / ("_fit%d" % iters) / name
    if not (out / "gaussians.ply").exists():
        run([CLI, "fit", "--dataset", data, "--gaussians", data / "gaussians.ply", "--out", out,
             "--iters", iters, "--seed", 0, "-q", "--threads", threads], log)
    return out / "gaussians.ply"


def scene_row(m, a, runs, tag_dir):
    data = Path(a.family) / m["name"]
    if not (data / "dataset.json").exists():
        raise RuntimeError("%s: no dataset (run bench/make_family.py)" % data)
    out = tag_dir / m["name"]
    log = str(out) + ".log"
    metrics = out / "eval" / "metrics.json"
    timing = out / "bench_time.json"
    if a.force or not metrics.exists():
        shutil.rmtree(out, ignore_errors=True)
        os.makedirs(tag_dir, exist_ok=True)
        budget = [] if a.defaults else ["--iters", a.iters, "--spp", a.spp]
        if a.fit_iters > 0:  # the fitted splats and the field's bounce light, as optimize after its fit stage
            start = ["--gaussians", fitted(data, runs, m["name"], a.fit_iters, a.threads, log), "--indirect", "field"]
        else:  # the dataset's splats as they are, path-traced bounce light (optimize --fit-iters 0)
            start = ["--gaussians", data / "gaussians.ply"]
        secs = run([CLI, "optimize", "--dataset", data, "--fit-iters", 0, "--out", out, "-q", "--threads", a.threads]
                   + start + budget + a.extra.replace("{data}", str(data)).split(), log)
        json.dump({"optimize_s": secs}, open(timing, "w"))
        run(eval_cmd(data, out, a.eval_spp, a.threads), log)
    r = json.load(open(metrics))
    o = oracle_metrics(data, a.eval_spp, a.threads, log)
    return {"name": m["name"], "half": m.get("half"), "albedo": r["albedo_psnr"], "albedo_oracle": o["albedo_psnr"],
            "scale": r["albedo_scale"], "relight": r["relight_psnr"], "relight_oracle": o["relight_psnr"],
            "rough": r["roughness_mse"], "rough_oracle": o["roughness_mse"], "nvs": r["nvs_psnr"],
            "seconds": json.load(open(timing))["optimize_s"] if timing.exists() else None,
            "sheets": [str(out / "eval" / s) for s in r.get("sheets", [])]}


def fmt(v, f="%.2f"):
    return "-" if v is None else f % v


def print_table(rows, title):
    print("\n" + title)
    print("| scene | half | albedo (oracle) | scale GT/ours r g b | relight (oracle) | rough MSE (oracle) | optimise s |")
    print("|---|---|---:|---|---:|---:|---:|")
    for r in rows:
        print("| %s | %s | %s (%s) | %s | %s (%s) | %s (%s) | %s |" % (
            r["name"], r["half"], fmt(r["albedo"]), fmt(r["albedo_oracle"]), " ".join("%.3f" % s for s in r["scale"]),
            fmt(r["relight"]), fmt(r["relight_oracle"]), fmt(r["rough"], "%.4f"), fmt(r["rough_oracle"], "%.4f"),
            fmt(r["seconds"], "%.0f")))
    summary = {}
    for key, worst in (("albedo", min), ("relight", min), ("rough", max), ("seconds", max)):
        vals = [r[key] for r in rows if r[key] is not None]
        summary[key] = {"mean": sum(vals) / len(vals), "worst": worst(vals)} if vals else None
    for key in ("albedo_oracle", "relight_oracle", "rough_oracle"):
        vals = [r[key] for r in rows if r[key] is not None]
        summary[key] = sum(vals) / len(vals) if vals else None
    scales = [r["scale"] for r in rows]
    summary["scale_mean"] = [sum(s[c] for s in scales) / len(scales) for c in range(3)]
    summary["scale_worst_dev"] = max(abs(s[c] - 1.0) for s in scales for c in range(3))
    print("| **mean** | | %s (%s) | %s | %s (%s) | %s (%s) | %s |" % (
        fmt(summary["albedo"]["mean"]), fmt(summary["albedo_oracle"]), " ".join("%.3f" % s for s in summary["scale_mean"]),
        fmt(summary["relight"]["mean"]), fmt(summary["relight_oracle"]), fmt(summary["rough"]["mean"], "%.4f"),
        fmt(summary["rough_oracle"], "%.4f"), fmt(summary["seconds"]["mean"], "%.0f")))
    print("| **worst** | | %s | max abs(scale - 1) %.3f | %s | %s | %s |" % (
        fmt(summary["albedo"]["worst"]), summary["scale_worst_dev"], fmt(summary["relight"]["worst"]),
        fmt(summary["rough"]["worst"], "%.4f"), fmt(summary["seconds"]["worst"], "%.0f")))
    return summary


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--half", default="tuning", choices=("tuning", "heldout", "all"))
    p.add_argument("--iters", type=int, default=300)
    p.add_argument("--spp", type=int, default=8)
    p.add_argument("--defaults", action="store_true", help="the command's own budget (no --iters / --spp)")
    p.add_argument("--fit-iters", type=int, default=FIT_ITERS,
                   help="geometry stage iterations, run once per scene (0: the set's splats as they are)")
    p.add_argument("--tag", default="default", help="the variant's name (its runs go to RUNS/<tag>-<budget>/)")
    p.add_argument("--extra", default="", help="optimize flags of the variant ({data}: the member's set folder)")
    p.add_argument("--only", default="")
    p.add_argument("--family", default=str(REPO / "out" / "family"))
    p.add_argument("--runs", default=str(REPO / "out" / "family_runs"))
    p.add_argument("--eval-spp", type=int, default=32)
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--force", action="store_true")
    a = p.parse_args()
    members = [m for m in family_def.members() if a.half == "all" or m["half"] == a.half]
    if a.only:
        members = [m for m in members if m["name"] in a.only.split(",")]
    runs = Path(a.runs)
    budget = ("defaults" if a.defaults else "%dx%d" % (a.iters, a.spp)) + "-fit%d" % a.fit_iters
    tag_dir = runs / ("%s-%s" % (a.tag, budget))
    rows = []
    for m in members:
        rows.append(scene_row(m, a, runs, tag_dir))
        r = rows[-1]
        print("%-16s albedo %s (oracle %s)  scale %s  relight %s  rough %s  %s s" % (
            r["name"], fmt(r["albedo"]), fmt(r["albedo_oracle"]), " ".join("%.3f" % s for s in r["scale"]),
            fmt(r["relight"]), fmt(r["rough"], "%.4f"), fmt(r["seconds"], "%.0f")), flush=True)
    summary = print_table(rows, "family, %s half, %s, variant '%s' %s" % (a.half, budget, a.tag, a.extra))
    worst = sorted(rows, key=lambda r: r["albedo"])[:3]
    wdir = tag_dir / "worst"
    shutil.rmtree(wdir, ignore_errors=True)
    os.makedirs(wdir)
    for rank, r in enumerate(worst, 1):
        for s in r["sheets"]:
            if os.path.exists(s):
                shutil.copyfile(s, wdir / ("%d_%s_%s" % (rank, r["name"], os.path.basename(s))))
    print("contact sheets of the worst three (%s): %s" % (", ".join(r["name"] for r in worst), wdir))
    json.dump({"half": a.half, "budget": budget, "tag": a.tag, "extra": a.extra, "rows": rows, "summary": summary},
              open(tag_dir / "summary.json", "w"), indent=1)


if __name__ == "__main__":
    main()
