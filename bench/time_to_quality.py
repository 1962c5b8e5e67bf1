#!/usr/bin/python3
"""Time to a relightable asset (issue 38): wall time until this build's `ptir optimize`
reaches the previous release's default result (800 iterations x 32 spp), and the quality
each reaches at fixed budgets.

    bench/time_to_quality.py --dataset out/tex128 [--dataset out/walls ...] [--out out/ttq]
        [--previous /work/baseline-952cb46/bin/ptir] [--build build] [--budgets 2,5,10]
        [--previous-iters 800] [--fit-iters 1500] [--threads 0] [--eval-spp 32] [--tolerance 0.2]

Per dataset, the previous release and this build run one after the other (previous first,
then this build's budgets, shortest first; run twice to alternate the other way) on the same
machine, each the whole command (geometry stage, inversion, outputs) timed by its wall clock
and its process CPU time (user + system: the ratio that survives a shared machine), then
`ptir eval` (--eval-spp, every relight environment of the set). Quality: albedo PSNR
(foreground, sRGB) and relight PSNR (mean over the relight environments).

The previous release's default run is the reference. Where it would take hours
(--previous-iters N < 800), N iterations are run and timed, the wall time of 800 is projected
(fit + setup + 800 x the run's mean s/iter, from its log.csv) and the reference quality is
not known (the table says so). "reached in" is the shortest budget of this build whose albedo
and relight are both within --tolerance dB of the reference (not interpolated: an upper bound),
and its fraction of the reference's wall time.

Writes OUT/<set>/<run>/ (kept and reused while the command is the same), OUT/ttq.md (the
table) and OUT/ttq.png (quality against minutes; matplotlib).

    bench/time_to_quality.py --plot-points POINTS.json --png OUT.png

plots runs measured by hand (a JSON list of {"label", "minutes", "albedo", "relight"}, optional
"marker", "color", "xlabel" and "series": points of one series are joined by a line; the docs'
plots, docs/time_to_quality.png and time_to_quality_budgets.png, are made so from
performance.md's tables).
"""

import argparse
import json
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_timed(cmd, log):
    """Runs cmd (stdout+stderr to log); returns (wall s, cpu s) of the child."""
    t = time.time()
    r0 = os.times()
    with open(log, "w") as f:
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    r1 = os.times()
    if r.returncode != 0:
        sys.exit("time_to_quality: failed (%s), see %s" % (" ".join(cmd[:2]), log))
    return time.time() - t, (r1.children_user - r0.children_user) + (r1.children_system - r0.children_system)


def optimise(a, exe, dataset, out_dir, flags):
    """One whole `ptir optimize` (reused when the same command finished before): its record."""
    os.makedirs(out_dir, exist_ok=True)
    result = os.path.join(out_dir, "result")
    cmd = [exe, "optimize", "--dataset", dataset, "--out", result, "--fit-iters", str(a.fit_iters), "-q", "--force"]
    if not os.path.exists(os.path.join(dataset, "cameras.json")) and os.path.exists(os.path.join(dataset, "gaussians.ply")):
        cmd += ["--gaussians", os.path.join(dataset, "gaussians.ply")]
    if a.threads:
        cmd += ["--threads", str(a.threads)]
    cmd += flags
    rec_path = os.path.join(out_dir, "record.json")
    if os.path.exists(rec_path):
        rec = json.load(open(rec_path))
        if rec.get("command") == cmd and os.path.exists(os.path.join(result, "eval", "metrics.json")):
            return rec
    wall, cpu = run_timed(["nice", "-n", str(a.nice)] + cmd, os.path.join(out_dir, "optimize.log"))
    meta = json.load(open(os.path.join(dataset, "dataset.json")))
    relight = []
    for name in meta.get("relight_envs", []):
        relight += ["--relight", "%s=%s" % (name, os.path.join(dataset, meta["envmaps"][name]))]
    run_timed(["nice", "-n", str(a.nice), a.ptir, "eval", "--dataset", dataset, "--result", result, "--spp",
               str(a.eval_spp), "-q", "--force", "--sheet-views", "0"] + relight, os.path.join(out_dir, "eval.log"))
    m = json.load(open(os.path.join(result, "eval", "metrics.json")))
    rel = [v["psnr"] for v in m.get("relight", {}).values()]
    rows = open(os.path.join(result, "log.csv")).read().splitlines()
    head = rows[0].split(",")
    secs = [float(r.split(",")[head.index("seconds")]) for r in rows[1:]] if "seconds" in head else []
    cpus = [float(r.split(",")[head.index("cpu_s")]) for r in rows[1:]] if "cpu_s" in head else []
    rec = {"command": cmd, "wall_s": wall, "cpu_s": cpu, "iterations": len(rows) - 1,
           "s_per_iter": sum(secs) / len(secs) if secs else None, "iter_s": sum(secs),
           "cpu_per_iter": sum(cpus) / len(cpus) if cpus else None, "iter_cpu_s": sum(cpus),
           "albedo": m.get("albedo_psnr"), "relight": sum(rel) / len(rel) if rel else None,
           "nvs": m.get("nvs_psnr"), "rough_mse": m.get("roughness_mse")}
    json.dump(rec, open(rec_path, "w"), indent=1)
    return rec


def fmt(v, d=2):
    return "n/a" if v is None else ("%%.%df" % d) % v


def plot_points(points_path, png_path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    points = json.load(open(points_path))
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, key in zip(axes, ("albedo", "relight")):
        series = {}  # points sharing a "series" are joined by a line (a build's budgets)
        for pt in points:
            if pt.get(key) is None:
                continue
            if pt.get("series"):
                series.setdefault(pt["series"], []).append(pt)
            else:
                ax.plot([pt["minutes"]], [pt[key]], pt.get("marker", "o"), label=pt["label"], color=pt.get("color"))
        for name, pts in series.items():
            pts.sort(key=lambda q: q["minutes"])
            ax.plot([q["minutes"] for q in pts], [q[key] for q in pts], pts[0].get("marker", "o") + "-", label=name,
                    color=pts[0].get("color"))
        ax.set_xscale("log")
        ax.set_xlabel(points[0].get("xlabel", "minutes"))
        ax.set_ylabel("%s PSNR (dB)" % key)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png_path, dpi=100)
    print("wrote", png_path)


def main():
    if "--plot-points" in sys.argv:
        q = argparse.ArgumentParser()
        q.add_argument("--plot-points", required=True)
        q.add_argument("--png", required=True)
        b = q.parse_args()
        return plot_points(b.plot_points, b.png)
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dataset", action="append", required=True)
    p.add_argument("--out", default=os.path.join(ROOT, "out", "ttq"))
    p.add_argument("--previous", default="/work/baseline-952cb46/bin/ptir", help="the previous release's ptir")
    p.add_argument("--build", default=os.path.join(ROOT, "build"))
    p.add_argument("--budgets", default="2,5,10", help="this build's budgets in minutes")
    p.add_argument("--previous-iters", type=int, default=800, help="< 800: a shortened reference, its time projected")
    p.add_argument("--fit-iters", type=int, default=1500)
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--nice", type=int, default=10)
    p.add_argument("--eval-spp", type=int, default=32)
    p.add_argument("--tolerance", type=float, default=0.2)
    a = p.parse_args()
    a.ptir = os.path.join(a.build, "bin", "ptir")
    budgets = [float(b) for b in a.budgets.split(",") if b]
    lines = ["| set | run | wall min | CPU min | iterations | albedo fg sRGB | relight | NVS | rough MSE |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    summary = ["| set | previous 800 × 32: wall min (albedo / relight) | reached in (budget) | fraction of its wall / CPU time |",
               "|---|---|---|---:|"]
    curves = {}
    for ds in a.dataset:
        name = os.path.basename(os.path.normpath(ds))
        base = os.path.join(a.out, name)
        shortened = a.previous_iters < 800
        prev = optimise(a, a.previous, ds, os.path.join(base, "previous_%d" % a.previous_iters),
                        ["--iters", str(a.previous_iters)])
        ref_wall, ref_cpu = prev["wall_s"], prev["cpu_s"]
        if shortened and prev["s_per_iter"]:  # 800 iterations at the shortened run's mean cost
            ref_wall = prev["wall_s"] - prev["iter_s"] + 800 * prev["s_per_iter"]
            if prev.get("cpu_per_iter"):
                ref_cpu = prev["cpu_s"] - prev["iter_cpu_s"] + 800 * prev["cpu_per_iter"]
        ours = []
        for b in budgets:
            r = optimise(a, a.ptir, ds, os.path.join(base, "budget_%gm" % b), ["--budget", "%gm" % b])
            r["budget_min"] = b
            ours.append(r)
        label = "previous, %d × 32%s" % (a.previous_iters, " (800 projected)" if shortened else "")
        lines.append("| %s | %s | %s | %s | %d | %s | %s | %s | %s |" % (
            name, label, fmt(ref_wall / 60, 1), fmt(ref_cpu / 60, 1), prev["iterations"], fmt(prev["albedo"]),
            fmt(prev["relight"]), fmt(prev["nvs"]), fmt(prev["rough_mse"], 4)))
        for r in ours:
            lines.append("| %s | --budget %gm | %s | %s | %d | %s | %s | %s | %s |" % (
                name, r["budget_min"], fmt(r["wall_s"] / 60, 1), fmt(r["cpu_s"] / 60, 1), r["iterations"],
                fmt(r["albedo"]), fmt(r["relight"]), fmt(r["nvs"]), fmt(r["rough_mse"], 4)))
        reached = None
        if not shortened:
            for r in ours:
                if r["albedo"] >= prev["albedo"] - a.tolerance and r["relight"] >= prev["relight"] - a.tolerance:
                    reached = r
                    break
        ref_q = "n/a (shortened)" if shortened else "%s / %s" % (fmt(prev["albedo"]), fmt(prev["relight"]))
        summary.append("| %s | %s (%s) | %s | %s |" % (
            name, fmt(ref_wall / 60, 1), ref_q,
            "%s min (%gm)" % (fmt(reached["wall_s"] / 60, 1), reached["budget_min"]) if reached else "not within the budgets",
            "%s / %s" % (fmt(reached["wall_s"] / ref_wall, 3), fmt(reached["cpu_s"] / ref_cpu, 3)) if reached else "–"))
        curves[name] = (prev, ref_wall, shortened, ours)
    text = "\n".join(summary) + "\n\n" + "\n".join(lines) + "\n"
    print(text)
    os.makedirs(a.out, exist_ok=True)
    open(os.path.join(a.out, "ttq.md"), "w").write(text)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("time_to_quality: no matplotlib (pip install matplotlib), no plot")
        return
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for name, (prev, ref_wall, shortened, ours) in curves.items():
        for ax, key in zip(axes, ("albedo", "relight")):
            xs = [r["wall_s"] / 60 for r in ours]
            line, = ax.plot(xs, [r[key] for r in ours], "o-", label="%s, this build (--budget)" % name)
            if not shortened and prev[key] is not None:
                ax.plot([ref_wall / 60], [prev[key]], "s", color=line.get_color(), label="%s, previous 800 × 32" % name)
                ax.axhline(prev[key] - a.tolerance, color=line.get_color(), lw=0.5, ls="--")
            ax.set_xscale("log")
            ax.set_xlabel("wall minutes (whole command)")
            ax.set_ylabel("%s PSNR (dB)" % key)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "ttq.png"), dpi=100)
    print("wrote", os.path.join(a.out, "ttq.md"), os.path.join(a.out, "ttq.png"))


if __name__ == "__main__":
    main()
