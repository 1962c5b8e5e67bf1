#!/usr/bin/python3
"""Inverse-rendering cost: seconds per iteration and peak memory of `ptir optimize`.

    bench/bench_optimize.py [--build build] [--threads 2] [--iters 4] [--quick]
                            [--only counts,pixels,bounces,threads] [--data-build BUILD]

Sweeps (each point is one `ptir optimize` process on a synthetic dataset):
  counts   Gaussian count 10K -> 1M (a sphere shell of flat Gaussians), 256x256, 8 spp, 2 bounces
  pixels   pixels x spp at 100K Gaussians: 128^2 / 256^2 / 512^2 x 8 / 32 spp, 2 bounces
  bounces  1 / 2 / 4 / 9 bounces at 100K and 1M Gaussians, 256x256, 8 spp (memory must stay flat)
  threads  1 thread .. --threads at 100K Gaussians, 256x256, 8 spp, 2 bounces: speed-up and peak RSS
           (the gradients are reduced over fixed pixel tiles, so memory should not grow with threads)
  walls    the speed issue's case: the same 100K Gaussians standing in a room of four mesh walls
           (`ptir optimize --scene`), 256x256, 8 spp, 2 bounces, 1 thread .. --threads
and prints, per point, wall-clock AND process-CPU-time / threads figures (the
machine is shared: CPU time is what the work costs on that many idle cores):
s/iter (median over iterations 2..N), the split primal /
backward (the replay: the primal pass keeps each sample's radiance) / regularisers
(material AOVs, TV, their adjoint), the replay / primal ratio, path samples per
second (pixels x spp / (primal + replay time), the throughput of the two passes the
estimator needs), and the process's peak RSS, also for a 0-iteration run of the
same inputs (load + BVH + normal orientation + outputs) to show what the loop adds.

Targets (ISSUE): >= 0.25 M path samples/s primal+replay on 2 cores for 100K
Gaussians at 2 bounces; replay <= 2x primal; peak RSS <= 1 GB for 1M Gaussians at
256x256 and <= 2 % higher at 9 bounces than at 1.

The dataset: N flat Gaussians (degree-0 SH): 80 % on a unit sphere (Fibonacci
lattice; warm top, cool bottom), 20 % on a 5 x 5 floor just below it (so that
light bounces between the two), under a sky with a sun; 2 views rendered by ptir
itself at each size. The walls variant adds four diffuse mesh walls 3 units from the
centre, 4 high, open to the sky (rays that miss the object end on a wall instead of
in the sky, as in a room), in the images and in the optimisation. A benchmark, not a test; the machine is shared, so compare within a run.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
from blender_kit import look_at  # noqa: E402


def fibonacci(n):
    i = np.arange(n, dtype=np.float64) + 0.5
    z = 1 - 2 * i / n
    r = np.sqrt(np.maximum(0, 1 - z * z))
    phi = i * math.pi * (3 - math.sqrt(5))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], 1)


def quat_z_to(n):
    """(w, x, y, z) rotating +z onto each unit row of n (vectorised; n.z = -1 handled)."""
    w = 1.0 + n[:, 2]
    q = np.stack([w, -n[:, 1], n[:, 0], np.zeros(len(n))], 1)  # cross((0,0,1), n) = (-n_y, n_x, 0)
    bad = w < 1e-9
    q[bad] = (0.0, 1.0, 0.0, 0.0)
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def positions(n):
    """n points: 80 % on the unit sphere, 20 % on a square floor 5 x 5 at z = -1.02 (so that
    light bounces between them and the bounce count matters), with in-plane spacings."""
    ns = n - n // 5
    nf = n - ns
    side = int(math.ceil(math.sqrt(nf)))
    g = (np.arange(side) + 0.5) / side * 5.0 - 2.5
    fx, fy = np.meshgrid(g, g)
    floor = np.stack([fx.ravel(), fy.ravel(), np.full(side * side, -1.02)], 1)[:nf]
    return np.concatenate([fibonacci(ns), floor]), ns, math.sqrt(4 * math.pi / ns), 5.0 / side


def write_ply(path, n):
    p, ns, spacing, floor_spacing = positions(n)
    names = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
             "rot_0", "rot_1", "rot_2", "rot_3"]
    rec = np.zeros(n, dtype=[(k, "<f4") for k in names])
    for i, c in enumerate("xyz"):
        rec[c] = p[:, i]
    rec["opacity"] = math.log(0.95 / 0.05)
    sigma = np.where(np.arange(n) < ns, 0.7 * spacing, 0.7 * floor_spacing)
    rec["scale_0"] = rec["scale_1"] = np.log(sigma)
    rec["scale_2"] = np.log(1e-3 * sigma)
    normal = p.copy()
    normal[ns:] = (0.0, 0.0, 1.0)
    q = quat_z_to(normal)
    for i in range(4):
        rec["rot_%d" % i] = q[:, i]
    header = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
    header += "".join("property float %s\n" % k for k in names) + "end_header\n"
    Path(path).write_bytes(header.encode("ascii") + rec.tobytes())
    return p


def dataset_paths(root, n, res, walls=False):
    return root / ("g%d.ply" % n), root / ("ds_%d_%d%s" % (n, res, "_walls" if walls else ""))


# The walls variant's room: four quads around the object, from the floor's height up.
WALL_HALF, WALL_LOW, WALL_HIGH = 3.0, -1.02, 3.0


def write_walls(ds):
    """ds/wall.ply (four inward-facing quads) and ds/scene.json naming it, with a diffuse
    Principled material; returns the scene file."""
    h, lo, hi = WALL_HALF, WALL_LOW, WALL_HIGH
    quads = [[(h, -h), (h, h)], [(-h, h), (-h, -h)], [(h, h), (-h, h)], [(-h, -h), (h, -h)]]
    verts, faces = [], []
    for (x0, y0), (x1, y1) in quads:
        b = len(verts)
        verts += [(x0, y0, lo), (x1, y1, lo), (x1, y1, hi), (x0, y0, hi)]
        faces += [(b, b + 1, b + 2), (b, b + 2, b + 3)]
    header = ("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
              "element face %d\nproperty list uchar int vertex_indices\nend_header\n" % (len(verts), len(faces)))
    body = "".join("%g %g %g\n" % v for v in verts) + "".join("3 %d %d %d\n" % f for f in faces)
    (ds / "wall.ply").write_text(header + body)
    scene = {"version": 1, "meshes": [{"name": "walls", "file": "wall.ply", "material": {
        "shader": "principled", "base_color": [0.6, 0.55, 0.5], "roughness": 1.0, "metallic": 0.0}}]}
    (ds / "scene.json").write_text(json.dumps(scene, indent=1))
    return ds / "scene.json"


def make_dataset(build, root, n, res, walls=False):
    """root/g<n>.ply (shared by sizes) and root/ds_<n>_<res>/ (2 views), made in a child
    process so that this one stays small (a forked child's peak RSS counts the parent's
    pages until it execs)."""
    ply, ds = dataset_paths(root, n, res, walls)
    if (ds / "transforms_train.json").exists() and ply.exists():
        return ply, ds
    r = subprocess.run([sys.executable, __file__, "--build", str(build), "--data", str(root), "--make", str(n), str(res),
                        str(int(walls))], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("bench_optimize: error: making the %d-Gaussian %dx%d dataset failed:\n%s" % (n, res, res, r.stderr[-2000:]))
    return ply, ds


def make_dataset_here(build, root, n, res, walls=False):
    sys.path.insert(0, str(build / "python"))
    import ptir
    ply, ds = dataset_paths(root, n, res, walls)
    ds.mkdir(parents=True, exist_ok=True)
    p = write_ply(ply, n) if not ply.exists() else positions(n)[0]
    floor = np.arange(n) >= positions(n)[1]
    env = np.zeros((16, 32, 3), np.float32)
    for r in range(16):
        env[r] = [1.6 - 0.07 * r, 1.4 - 0.06 * r, 1.0] if r < 8 else [0.35, 0.3, 0.25]
    env[3, 9] = [40, 36, 30]
    ptir.write_image(str(ds / "env.exr"), env)
    frames = []
    for i in range(2):
        phi = math.pi * i
        # Close enough that the sphere fills most of the frame.
        frames.append({"file_path": "./train_%03d/rgba" % i,
                       "transform_matrix": look_at((2.2 * math.cos(phi), 2.2 * math.sin(phi), 0.8), (0, 0, 0)).tolist()})
    (ds / "transforms_train.json").write_text(json.dumps({"camera_angle_x": 0.9, "w": res, "h": res, "frames": frames}))
    desc = {"gaussians": [{"file": str(ply)}], "environment": {"type": "latlong", "file": "env.exr"},
            "cameras": [{"transforms": "transforms_train.json"}]}
    if walls:
        desc["meshes"] = json.loads(write_walls(ds).read_text())["meshes"]
    scene = ptir.scene_from_dict(desc, base_dir=str(ds))
    g = scene.gaussians
    albedo = np.where(p[:, 2:3] > 0, [[0.7, 0.3, 0.2]], [[0.2, 0.5, 0.7]])
    albedo[floor] = 0.5
    g.albedo = albedo.astype(np.float32)
    g.roughness = np.where(floor, 0.8, np.where(p[:, 2] > 0, 0.3, 0.7)).astype(np.float32)
    for i in range(2):
        img = scene.render(i, spp=4, bounces=2)
        (ds / ("train_%03d" % i)).mkdir(exist_ok=True)
        ptir.write_image(str(ds / ("train_%03d" % i) / "rgba.png"), img)


def run_point(cli, ply, ds, out, iters, spp, bounces, threads):
    cmd = [str(cli), "optimize", "--dataset", str(ds), "--gaussians", str(ply), "--out", str(out), "--iters", str(iters),
           "--spp", str(spp), "--bounces", str(bounces), "--threads", str(threads), "--checkpoint-every", "0", "-q",
           "--fit-iters", "0"]
    if (ds / "scene.json").exists():
        cmd += ["--scene", str(ds / "scene.json")]
    t0 = time.time()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.time() - t0
    err = proc.stderr.read().decode()
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit("bench_optimize: error: %s\n%s" % (" ".join(cmd), err[-2000:]))
    rss_mb = usage.ru_maxrss / 1024.0
    rows = []
    if iters > 0:
        lines = (out / "log.csv").read_text().splitlines()
        head = lines[0].split(",")
        for l in lines[1:]:
            v = l.split(",")
            rows.append({k: float(v[i]) for i, k in enumerate(head[:-1])})
    return rows, rss_mb, wall


def summarise(rows, pixels, spp, threads):
    use = rows[1:] if len(rows) > 1 else rows
    med = lambda k: float(np.median([r[k] for r in use]))
    it, pr, bw, rg = med("seconds"), med("primal_s"), med("backward_s"), med("regulariser_s")
    # CPU time / threads: what the passes take on that many otherwise idle cores.
    cpu_it, cpu_pr, cpu_bw = med("cpu_s") / threads, med("primal_cpu_s") / threads, med("backward_cpu_s") / threads
    # The primal pass keeps each sample's radiance (optimizer.h: sample_cache_bytes, 256 MB,
    # which every point here fits), so the backward pass is the replay alone.
    samples = pixels * spp
    return {"s_iter": it, "primal": pr, "backward": bw, "reg": rg, "replay_over_primal": bw / pr,
            "msps": samples / (pr + bw) / 1e6, "cpu_s_iter": cpu_it, "cpu_replay_over_primal": cpu_bw / cpu_pr,
            "cpu_msps": samples / (cpu_pr + cpu_bw) / 1e6}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--iters", type=int, default=4)
    ap.add_argument("--quick", action="store_true", help="smaller sweeps (no 1M, no 512^2)")
    ap.add_argument("--only", default="counts,pixels,bounces")
    ap.add_argument("--data", default=str(ROOT / "out" / "bench_optimize"))
    ap.add_argument("--data-build", help="build whose Python module makes the datasets (default: --build)")
    ap.add_argument("--make", nargs=3, type=int, metavar=("N", "RES", "WALLS"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    build = Path(args.build) if Path(args.build).is_absolute() else Path.cwd() / args.build
    root = Path(args.data)
    root.mkdir(parents=True, exist_ok=True)
    if args.make:
        make_dataset_here(build, root, *args.make)
        return
    cli = build / "bin" / "ptir"
    if not cli.exists():
        sys.exit("bench_optimize: error: %s not found (build first)" % cli)
    only = set(args.only.split(","))
    data_build = Path(args.data_build).resolve() if args.data_build else build

    results = []

    def point(sweep, n, res, spp, bounces, threads=None, walls=False):
        threads = threads or args.threads
        ply, ds = make_dataset(data_build, root, n, res, walls)
        out = root / "runs" / ("%s_%d_%d_%d_%d_t%d" % (sweep, n, res, spp, bounces, threads))
        rows, rss, wall = run_point(cli, ply, ds, out, args.iters, spp, bounces, threads)
        _, rss0, _ = run_point(cli, ply, ds, root / "runs" / "load_only", 0, spp, bounces, threads)
        s = summarise(rows, res * res, spp, threads)
        s.update(sweep=sweep, gaussians=n, res=res, spp=spp, bounces=bounces, threads=threads, rss_mb=rss, rss0_mb=rss0)
        results.append(s)
        print("%-8s %8d %4d^2 %3d spp %d bnc %2d thr | wall %7.3f s/it (primal %6.3f replay %6.3f reg %5.3f) %5.3f Msps"
              " | cpu/%d %7.3f s/it, replay/primal %4.2f, %5.3f Msps | peak RSS %7.1f MB (load only %7.1f)"
              % (sweep, n, res, spp, bounces, threads, s["s_iter"], s["primal"], s["backward"], s["reg"], s["msps"],
                 threads, s["cpu_s_iter"], s["cpu_replay_over_primal"], s["cpu_msps"], rss, rss0), flush=True)
        return s

    print("bench_optimize: %d threads, %d iterations per point (medians exclude the first)" % (args.threads, args.iters))
    counts = [10_000, 100_000] if args.quick else [10_000, 100_000, 1_000_000]
    if "counts" in only:
        for n in counts:
            point("counts", n, 256, 8, 2)
    if "pixels" in only:
        for res in ([128, 256] if args.quick else [128, 256, 512]):
            for spp in (8, 32):
                point("pixels", 100_000, res, spp, 2)
    if "bounces" in only:
        for n in ([100_000] if args.quick else [100_000, 1_000_000]):
            for b in (1, 2, 4, 9):
                point("bounces", n, 256, 8, b)
            sel = [r for r in results if r["sweep"] == "bounces" and r["gaussians"] == n]
            r1 = next(r for r in sel if r["bounces"] == 1)
            r9 = next(r for r in sel if r["bounces"] == 9)
            print("bounces %d Gaussians: peak RSS at 9 bounces / at 1 = %.4f" % (n, r9["rss_mb"] / r1["rss_mb"]))
    if "threads" in only:
        sel = [point("threads", 100_000, 256, 8, 2, t) for t in sorted({1, args.threads})]
        for s in sel:
            print("threads %2d: speed-up (wall) %.2f, (CPU-time model: cpu s/it on idle cores) %.2f; peak RSS %.1f MB"
                  % (s["threads"], sel[0]["s_iter"] / s["s_iter"], sel[0]["cpu_s_iter"] / s["cpu_s_iter"], s["rss_mb"]))
    if "walls" in only:
        for t in sorted({1, args.threads}):
            point("walls", 100_000, 256, 8, 2, t, walls=True)
    (root / "results.json").write_text(json.dumps(results, indent=1))
    print("bench_optimize: results in %s" % (root / "results.json"))


if __name__ == "__main__":
    main()
