"""bpy.ops.ptir.make_relightable in blender -b (run by test_addon_relightable.py).

    blender -b ... -P addon_relightable_check.py -- MODE PLY WORK_DIR [ITERATIONS]

PLY: a splat file from "another tool" with the DC colour only (SH degree 0, no material, no normals).
MODE
  finish   the duration estimate with Views "Splats' Own Radiance"; then no dataset folder: the operator renders the splats' own radiance and recovers materials from
           it; the splat attributes equal the engine's gaussians.ply, the world gets the recovered
           environment, roughness stays at its prior (SH degree 0) and the albedo takes the splats' hue;
           prints "RELIGHTABLE_STATS: {json}"
  cancel   a long run cancelled after a few seconds (as Esc does): nothing in the scene changed
"""

import json
import os
import sys
import threading
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402

h.enable_addon()
from ptir_blender.blender import splat_object  # noqa: E402
from ptir_blender.io import splat_ply  # noqa: E402
from ptir_blender.operators import optimize_ops  # noqa: E402


def build_scene(ply):
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=ply)
    h.check(r == {"FINISHED"}, "import")
    world = bpy.data.worlds.new("Plain")
    bpy.context.scene.world = world
    return bpy.context.active_object


def snapshot(splats):
    d = splat_object.read_data_from_object(splats)
    world = bpy.context.scene.world
    return {"albedo": d.albedo.copy(), "roughness": d.roughness.copy(), "normal": d.normal.copy(),
            "world": world.name, "world_nodes": sorted(n.name for n in world.node_tree.nodes) if world.node_tree
            else [], "images": sorted(i.name for i in bpy.data.images)}


def run_op(**kw):
    try:
        return bpy.ops.ptir.make_relightable(**kw), ""
    except RuntimeError as e:  # ERROR reports raise in scripts
        return {"CANCELLED"}, str(e)


def main():
    mode, ply, work = h.argv()[:3]
    iterations = int(h.argv()[3]) if len(h.argv()) > 3 else 40
    splats = build_scene(ply)
    before = snapshot(splats)
    s = bpy.context.scene.ptir_optimize
    s.source, s.dataset_dir = "DATASET", ""  # no folder: the splats' own radiance
    s.splat_object = splats
    s.env, s.env_width, s.env_height = "latlong", 16, 8
    s.output_dir = os.path.join(work, "out")
    stats = {"mode": mode}
    if mode == "finish":
        # The duration estimate without photos (Views: Splats' Own Radiance): one target rendered, the probe.
        s.source, s.iterations, s.spp, s.crop = "SPLATS", 40, 4, 0
        h.check(bpy.ops.ptir.optimize_estimate() == {"FINISHED"}, "estimate")
        from ptir_blender.blender import optimize_estimate
        total = optimize_estimate.seconds(bpy.context, s)
        h.check(total is not None and s.estimate_s_per_iter > 0 and s.estimate_setup_s > 0,
                "an estimate: %s s (%s s/iter)" % (total, s.estimate_s_per_iter))
        stats["estimate_s"] = total
        s.source = "DATASET"
        t0 = time.perf_counter()
        result, msg = run_op(iterations=iterations, samples=4, views=8, size=64)
        stats["seconds"] = time.perf_counter() - t0
        h.check(result == {"FINISHED"}, "make_relightable returned %s %s" % (result, msg))
        out = os.path.join(work, "out")
        h.check(os.path.isfile(os.path.join(out, "views.json")), "the virtual views were written")
        got = splat_object.read_data_from_object(splats)
        res = splat_ply.read_splat_ply(os.path.join(out, "gaussians.ply"))
        for f in ("albedo", "roughness", "metallic"):
            h.check(np.array_equal(getattr(got, f), np.clip(getattr(res, f), 0, 1)), "%s written back" % f)
        # SH degree 0: roughness is unconstrained and stays at its prior (0.6) exactly.
        h.check(np.all(got.roughness == np.float32(0.6)), "roughness at its prior: %s" % np.unique(got.roughness))
        mean = got.albedo.mean(axis=0)
        stats["albedo_mean"] = mean.tolist()
        h.check(np.all(np.isfinite(got.albedo)), "finite albedo")
        # The splats are orange (DC 0.8, 0.4, 0.15): the recovered albedo keeps that order of channels.
        h.check(mean[0] > mean[1] > mean[2], "albedo takes the splats' hue: %s" % mean)
        env = bpy.context.scene.world.node_tree.nodes.get("PTIR Environment")
        h.check(env is not None and env.image is not None, "the world has the recovered Environment Texture")
        h.check(s.status.startswith("done"), "status line: %s" % s.status)
    elif mode == "cancel":
        timer = threading.Timer(6.0, optimize_ops.request_cancel)
        timer.start()
        t0 = time.perf_counter()
        result, msg = run_op(iterations=100000, samples=4, views=8, size=64)
        stats["seconds"] = time.perf_counter() - t0
        h.check(result == {"CANCELLED"}, "a cancelled run returns CANCELLED (%s)" % result)
        problem = None
        after = snapshot(splats)
        for k in before:
            same = np.array_equal(before[k], after[k]) if isinstance(before[k], np.ndarray) else before[k] == after[k]
            if not same:
                problem = k
        h.check(problem is None, "a cancelled run changed the scene: %s" % problem)
        h.check(s.status == "cancelled", s.status)
    else:
        raise SystemExit("unknown mode " + mode)
    h.check(not s.running, "no job left running")
    print("RELIGHTABLE_STATS: " + json.dumps(stats), flush=True)


h.run(main)
