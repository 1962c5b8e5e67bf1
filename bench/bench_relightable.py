#!/usr/bin/env python3
"""Materials from a splat PLY alone (`ptir optimize --gaussians IN.ply`, no --dataset) against the
photo-based inversion, and the time of a 100K-splat object (docs/relightable.md).

    bench/bench_relightable.py compare --dataset DIR --out OUT [--iters 300] [--spp 16] [--fit-iters 1500]
    bench/bench_relightable.py speed --ply FITTED.ply --out OUT [--splats 100000] [--threads 2]

compare: on one of the project's textured Cycles sets (scripts/make_dataset.py --textured), `ptir fit`
fits the dataset's splats to the photos (their SH radiance learnt: what a capture app exports), then
from that one fitted PLY
    photos    ptir optimize --dataset DIR --gaussians FIT --fit-iters 0 (the photos and poses)
    ply_same  ptir optimize --gaussians FIT, virtual views at the photos' count and size, whole images
              (the same iterations x spp and pixels per iteration as `photos`)
    ply_auto  ptir optimize --gaussians FIT at the command's own defaults
and `ptir eval` scores each against the dataset's test views. Prints a Markdown table.

speed: a ~N-splat object made from FITTED.ply (each splat split into k smaller ones scattered inside
it, SH kept), then `ptir optimize --gaussians` at the command's defaults under --threads; prints the
wall time and the process's CPU time (user + sys).
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "addon"))
from ptir_blender.io import splat_ply  # noqa: E402


def run(cmd, log=None):
    """Runs cmd; returns (wall seconds, child CPU seconds)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    with open(log, "w") if log else open(os.devnull, "w") as f:
        r = subprocess.run([str(c) for c in cmd], stdout=f, stderr=subprocess.STDOUT)
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        raise SystemExit("failed (%d): %s (log: %s)" % (r.returncode, " ".join(map(str, cmd)), log))
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def compare(a):
    ptir = os.path.join(a.build, "bin", "ptir")
    fit = os.path.join(a.out, "fit")
    if not os.path.isfile(os.path.join(fit, "gaussians.ply")):
        run([ptir, "fit", "--dataset", a.dataset, "--gaussians", os.path.join(a.dataset, "gaussians.ply"), "--out", fit,
             "--iters", a.fit_iters, "-q"], os.path.join(a.out, "fit.log"))
    fitted = os.path.join(fit, "gaussians.ply")
    tr = json.load(open(os.path.join(a.dataset, "transforms_train.json")))
    n_views, size = len(tr["frames"]), tr.get("w") or 0
    if not size:
        from PIL import Image
        size = Image.open(os.path.join(a.dataset, tr["frames"][0]["file_path"] + ".png")).size[0]
    same = ["--iters", a.iters, "--spp", a.spp]
    rows = {
        "photos": ["optimize", "--dataset", a.dataset, "--gaussians", fitted, "--fit-iters", "0", *same],
        "ply_same": ["optimize", "--gaussians", fitted, *same, "--crop", "0", "--orbit-views", n_views,
                     "--orbit-size", size],
        "ply_auto": ["optimize", "--gaussians", fitted],
    }
    meta = json.load(open(os.path.join(a.dataset, "dataset.json")))
    relight = [x for env in meta.get("relight_envs", [])
               for x in ("--relight", "%s=%s" % (env, os.path.join(a.dataset, meta["envmaps"][env])))]
    table = ["| run | albedo PSNR (dB) | relight PSNR (dB) | roughness MSE | NVS PSNR (dB) | minutes (wall) | CPU minutes |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for name, cmd in rows.items():
        out = os.path.join(a.out, name)
        wall, cpu = run([ptir, *cmd, "--out", out, "--force", "-q"], os.path.join(a.out, name + ".log"))
        run([ptir, "eval", "--dataset", a.dataset, "--result", out, *relight, "-q", "--force"],
            os.path.join(a.out, name + "_eval.log"))
        m = json.load(open(os.path.join(out, "eval", "metrics.json")))
        rel = m.get("relight_psnr")
        table.append("| %s | %.2f | %s | %s | %.2f | %.1f | %.1f |" % (
            name, m["albedo_psnr"], "%.2f" % rel if rel is not None else "-",
            "%.4f" % m["roughness_mse"] if m.get("roughness_mse") is not None else "-", m["nvs_psnr"], wall / 60,
            cpu / 60))
        print(table[-1], flush=True)
    text = "\n".join(table)
    print(text)
    open(os.path.join(a.out, "relightable.md"), "w").write(text + "\n")


def speed(a):
    ptir = os.path.join(a.build, "bin", "ptir")
    os.makedirs(a.out, exist_ok=True)
    d = splat_ply.read_splat_ply(a.ply)
    k = max(1, int(round(a.splats / len(d))))
    rng = np.random.default_rng(1)
    idx = np.repeat(np.arange(len(d)), k)
    big = d.subset(idx)
    # Scattered inside the parent: offsets of one sigma along its axes, scales shrunk by k^(1/2) (flat splats).
    from ptir_blender.io.splat_transform import quat_to_matrix
    rot = quat_to_matrix(big.rotation.astype(np.float64))
    off = rng.normal(size=(len(big), 3)) * big.scale * np.array([0.6, 0.6, 0.0])
    big.position = (big.position + np.einsum("nij,nj->ni", rot, off)).astype(np.float32)
    big.scale = (big.scale / np.sqrt(k)).astype(np.float32)
    ply = os.path.join(a.out, "object_%d.ply" % len(big))
    splat_ply.write_splat_ply(ply, big, comment="bench_relightable speed object")
    out = os.path.join(a.out, "run")
    wall, cpu = run([ptir, "optimize", "--gaussians", ply, "--out", out, "--threads", a.threads, "--force"],
                    os.path.join(a.out, "run.log"))
    print("| splats | SH degree | threads | wall (min) | CPU (min) |\n|---:|---:|---:|---:|---:|\n| %d | %d | %s | %.1f | %.1f |"
          % (len(big), big.sh_degree, a.threads, wall / 60, cpu / 60))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="what", required=True)
    c = sub.add_parser("compare")
    c.add_argument("--dataset", required=True)
    c.add_argument("--out", required=True)
    c.add_argument("--iters", default="300")
    c.add_argument("--spp", default="16")
    c.add_argument("--fit-iters", default="1500")
    s = sub.add_parser("speed")
    s.add_argument("--ply", required=True)
    s.add_argument("--out", required=True)
    s.add_argument("--splats", type=int, default=100000)
    s.add_argument("--threads", default="2")
    for q in (c, s):
        q.add_argument("--build", default=os.path.join(ROOT, "build"))
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    (compare if a.what == "compare" else speed)(a)


if __name__ == "__main__":
    main()
