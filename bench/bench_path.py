#!/usr/bin/python3
"""Path-tracing benchmark: the heterogeneous sample scene, ours vs Cycles, spp and bounce scaling.

    bench/bench_path.py [--build build] [--subdiv 4] [--res 256] [--spp 32] [--bounces 2]
                        [--threads N] [--quick] [--no-cycles]

Scene (bench/bench_path_blender.py, built by Blender in this run): the bundled
sample object (Suzanne on a pedestal, scripts/make_sample_splat.py; --subdiv 4 gives
~130K surface Gaussians) as flat Gaussians, a mesh floor and two mesh walls, a
rectangular area light and a lat-long environment; 256 x 256, 32 spp, 2 bounces.

Measured, all in one run on this machine (ours and Cycles --repeat times each, medians):
  - ours on the heterogeneous scene (Gaussians + meshes): render seconds and path
    samples per second (pixels x spp / render time; BVH build and loading are
    reported separately);
  - Cycles (blender -b, CPU, same threads; its whole render operation: sync, BVH
    build, path tracing, EXR written) on the mesh-only version of the scene (the
    object as its triangle mesh, Principled BSDFs) at the same resolution, spp and
    bounces, and ours on that same mesh-only scene: ratio of render times ours /
    Cycles; also the mean-image difference ours(mesh) vs Cycles as a sanity check;
  - ours with the inversion's estimator (every light at every vertex, no Russian
    roulette) against the default, Cycles' (one light per vertex, roulette);
  - the cost of the BSDF: the heterogeneous scene with the default Principled
    BSDF against the paper's simplified Disney BRDF (--brdf disney-simplified);
  - spp scaling (8, 16, 32, 64) and bounce scaling (0, 1, 2, 4, 8) of ours on the
    heterogeneous scene.
A benchmark, not a test: the machine may be shared, so compare ratios within a run.
"""

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def make_environment(ptir, path, width=128, height=64):
    """Sky gradient, ground, and a sun patch (the same construction as the Cycles comparison test)."""
    u, t = np.meshgrid((np.arange(width) + 0.5) / width, (np.arange(height) + 0.5) / height)
    phi = (0.5 - u) * 2.0 * math.pi
    elev = (0.5 - t) * math.pi
    d = np.stack([np.cos(elev) * np.cos(phi), np.cos(elev) * np.sin(phi), np.sin(elev)], -1)
    up = np.clip(d[..., 2:3], 0.0, 1.0)
    img = np.where(d[..., 2:3] >= 0.0, np.array([0.35, 0.55, 1.0]) * (0.25 + 0.75 * (1.0 - up) ** 2),
                   np.array([0.12, 0.10, 0.08]))
    az, el = math.radians(-60.0), math.radians(40.0)
    sun = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    img[d @ sun > math.cos(math.radians(8.0))] = np.array([25.0, 23.0, 19.0])
    ptir.write_image(str(path), img.astype(np.float32))


def ours(cli, scene, out_dir, tag, spp, bounces, threads, brdf=None, repeat=1):
    """`ptir render` `repeat` times: the stats of the run with the median render time, plus
    every run's render seconds ("render_all")."""
    out = out_dir / ("ours_%s.exr" % tag)
    stats = out_dir / ("ours_%s.json" % tag)
    cmd = [str(cli), "render", str(scene), "-o", str(out), "--spp", str(spp), "--bounces", str(bounces),
           "--threads", str(threads), "--stats-json", str(stats), "-q"] + (["--brdf", brdf] if brdf else [])
    runs = []
    for _ in range(max(1, repeat)):
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit("bench_path: error: ptir render failed:\n" + r.stderr[-3000:])
        runs.append(json.loads(stats.read_text()))
    runs.sort(key=lambda s: s["render_s"])
    s = runs[len(runs) // 2]
    s["render_all"] = [x["render_s"] for x in runs]
    s["image"] = out
    return s


def spread(values):
    """'min-max' of a list of seconds."""
    return "%.2f-%.2f" % (min(values), max(values))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--build", default="build")
    p.add_argument("--subdiv", type=int, default=4)
    p.add_argument("--res", type=int, default=256)
    p.add_argument("--spp", type=int, default=32)
    p.add_argument("--bounces", type=int, default=2)
    p.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    p.add_argument("--out", default=str(ROOT / "out" / "bench_path"))
    p.add_argument("--quick", action="store_true", help="skip the spp and bounce scaling")
    p.add_argument("--no-cycles", action="store_true")
    p.add_argument("--repeat", type=int, default=3,
                   help="timed runs of ours and of Cycles for the comparison (the median is reported)")
    args = p.parse_args()

    build = Path(args.build)
    if not build.is_absolute():
        build = Path.cwd() / build
    cli = build / "bin" / "ptir"
    if not cli.exists() or not any((build / "python").glob("ptir*.so")):
        sys.exit("bench_path: error: build %s first (needs bin/ptir and python/ptir*.so)" % build)
    sys.path.insert(0, str(build / "python"))
    import ptir

    blender = shutil.which("blender")
    if blender is None:
        sys.exit("bench_path: error: blender not found")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    env = out / "sky.exr"
    make_environment(ptir, env)

    print("bench_path: building the scene in Blender%s ..." % ("" if args.no_cycles else " and timing Cycles"),
          flush=True)
    cmd = [blender, "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1",
           "-P", str(ROOT / "bench" / "bench_path_blender.py"), "--", "--out", str(out), "--env", str(env),
           "--subdiv", str(args.subdiv), "--res", str(args.res), "--spp", str(args.spp),
           "--bounces", str(args.bounces), "--threads", str(args.threads), "--repeat", str(args.repeat)] + \
        (["--no-cycles"] if args.no_cycles else [])
    t0 = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("bench_path: error: Blender failed:\n" + r.stdout[-3000:] + r.stderr[-3000:])
    info = json.loads(next(l for l in r.stdout.splitlines() if l.startswith("PTIR_BENCH_JSON: ")).split(": ", 1)[1])
    print("bench_path: Blender step %.1f s: %d Gaussians (object: %d polygons)"
          % (time.time() - t0, info["gaussians"], info["object_polygons"]), flush=True)

    hetero, mesh = Path(info["hetero_scene"]), Path(info["mesh_scene"])
    pixels = args.res * args.res
    rows = []

    def row(label, s):
        rows.append((label, s["gaussians"], s["triangles"], s["spp"], s["bounces"], s["render_s"],
                     spread(s["render_all"]), s["path_samples"] / s["render_s"], s["build_s"], s["load_s"]))
        print("  %-34s %6.2f s" % (label, s["render_s"]), flush=True)

    main_run = ours(cli, hetero, out, "hetero", args.spp, args.bounces, args.threads, repeat=args.repeat)
    row("ours: Gaussians + meshes", main_run)
    mesh_run = ours(cli, mesh, out, "mesh", args.spp, args.bounces, args.threads, repeat=args.repeat)
    row("ours: mesh-only version", mesh_run)
    disney_run = ours(cli, hetero, out, "hetero_disney", args.spp, args.bounces, args.threads, "disney-simplified")
    row("ours: Gaussians + meshes, paper BRDF", disney_run)
    # The inversion's estimator (every light at every vertex, no Russian roulette) on
    # the same scene: what Cycles' one-light pick and roulette save.
    doc = json.loads(hetero.read_text())
    doc.setdefault("integrator", {}).update({"light_selection": "all", "russian_roulette": False})
    every_light = hetero.with_name("scene_every_light.json")
    every_light.write_text(json.dumps(doc, indent=1))
    every_run = ours(cli, every_light, out, "hetero_every_light", args.spp, args.bounces, args.threads,
                     repeat=args.repeat)
    row("ours: Gaussians + meshes, every light, no roulette", every_run)
    scaling = []
    if not args.quick:
        for spp in (8, 16, 32, 64):
            s = main_run if spp == args.spp else ours(cli, hetero, out, "spp%d" % spp, spp, args.bounces, args.threads)
            scaling.append(("spp", spp, s))
        for b in (0, 1, 2, 4, 8):
            s = main_run if b == args.bounces else ours(cli, hetero, out, "b%d" % b, args.spp, b, args.threads)
            scaling.append(("bounces", b, s))

    print()
    print("Heterogeneous sample scene, %d x %d, %d spp, %d bounces, %d threads (%s)"
          % (args.res, args.res, args.spp, args.bounces, args.threads, os.uname().nodename))
    print()
    print("| renderer / scene | Gaussians | triangles | spp | bounces | render s (median) | min-max | path samples/s"
          " | BVH+setup s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for label, g, t, spp, b, secs, mm, rate, build_s, _ in rows:
        print("| %s | %d | %d | %d | %d | %.2f | %s | %.3g | %.2f |" % (label, g, t, spp, b, secs, mm, rate, build_s))
    if not args.no_cycles:
        cycles_all = sorted(info["cycles_seconds"])
        cyc = cycles_all[len(cycles_all) // 2]
        tris_mesh = mesh_run["triangles"]
        print("| Cycles 3.4 (CPU): mesh-only version, whole render operation (sync, BVH, EXR) | 0 | %d | %d | %d | %.2f"
              " | %s | %.3g | (first render: %.2f s) |"
              % (tris_mesh, args.spp, args.bounces, cyc, spread(cycles_all), pixels * args.spp / cyc,
                 info["cycles_seconds_first"]))
        print()
        print("ratio ours / Cycles (render time, medians of %d): Gaussians + meshes %.2f, mesh-only %.2f"
              % (len(cycles_all), main_run["render_s"] / cyc, mesh_run["render_s"] / cyc))
        print("ratio ours (BVH build + render) / Cycles' whole render: Gaussians + meshes %.2f, mesh-only %.2f"
              % ((main_run["build_s"] + main_run["render_s"]) / cyc, (mesh_run["build_s"] + mesh_run["render_s"]) / cyc))
        ref = np.load(out / "cycles.npy")
        img = ptir.read_image(str(mesh_run["image"]))[..., :3]
        cl = lambda a: np.minimum(a, 1.0)  # noqa: E731
        print("sanity: mean image ours(mesh) / Cycles = %.4f (both %d spp; same Principled materials)"
              % (float(cl(img).mean()) / float(cl(ref).mean()), args.spp))
    print()
    t_ratio = main_run["render_s"] / disney_run["render_s"]
    v_ratio = (main_run["vertices"] / main_run["paths"]) / (disney_run["vertices"] / disney_run["paths"])
    print("BSDF cost: render time Principled (default) / simplified Disney (--brdf disney-simplified) = %.3f;"
          " path vertices %.3f (the Principled sampler wastes fewer samples below the horizon, so more paths"
          " go on); time per vertex %.3f" % (t_ratio, v_ratio, t_ratio / v_ratio))
    if scaling:
        print()
        print("Scaling of ours on the heterogeneous scene")
        print()
        print("| varied | value | render s | path samples/s | vertices/path | shadow rays/path |")
        print("|---|---:|---:|---:|---:|---:|")
        for what, v, s in scaling:
            print("| %s | %d | %.2f | %.3g | %.2f | %.2f |" % (what, v, s["render_s"], s["path_samples"] / s["render_s"],
                                                              s["vertices"] / s["paths"], s["shadow_rays"] / s["paths"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
