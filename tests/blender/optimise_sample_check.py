"""The one-click optimise sample (sample_blends/make_optimise_sample.py), opened in blender -b (run by
test_optimise_sample.py).

    blender -b SAMPLE.blend ... -P optimise_sample_check.py -- ITERATIONS

Checks: the panel's dataset path is relative to the .blend ("//...") and resolves to the dataset; the
duration estimate saved with the file is valid for the file's settings; Optimise, pressed as it is
(only the iteration count lowered), writes recovered materials back (albedo, roughness changed from
the engine defaults the sample starts with, all within [0, 1]) and the recovered environment into the world.
Prints "SAMPLE_STATS: {json}" with the estimate for that iteration count, measured again now, against
the run's measured duration (printed, not asserted: a timed assertion fails with the machine's load).
"""

import json
import os
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402

h.enable_addon()
from ptir_blender.blender import optimize_estimate, splat_object  # noqa: E402
from ptir_blender.operators import render_engine  # noqa: E402


def main():
    iterations = int(h.argv()[0])
    context = bpy.context
    s = context.scene.ptir_optimize
    h.check(s.source == "DATASET" and s.dataset_dir.startswith("//"), "dataset path not relative: %r" % s.dataset_dir)
    folder = bpy.path.abspath(s.dataset_dir)
    h.check(os.path.isfile(os.path.join(folder, "transforms_train.json")), "dataset path does not resolve: %s" % folder)
    h.check(optimize_estimate.dataset_problem(s) is None, "panel reports a dataset problem")
    saved = optimize_estimate.seconds(context, s)
    h.check(saved is not None and saved > 0, "no duration estimate saved for the file's settings")
    obj = s.splat_object
    h.check(splat_object.is_splat_object(obj), "the panel names no splat object")
    albedo0, rough0, _ = (np.array(a) for a in splat_object.read_material_attributes(obj.data))

    # The estimate for the test's iteration count, measured now (same load as the run that follows).
    s.iterations = iterations
    optimize_estimate.measure(context, s, render_engine.cli_path())
    estimate = optimize_estimate.seconds(context, s)
    t0 = time.monotonic()
    r = bpy.ops.ptir.optimize()
    measured = time.monotonic() - t0
    h.check(r == {"FINISHED"}, "optimise: %s (%s)" % (r, s.status))
    albedo, rough, metallic = splat_object.read_material_attributes(obj.data)
    # Against the starting values' mean: the geometry stage (Fit Geometry, Auto) changes the count.
    change = float(np.abs(albedo - albedo0.mean(axis=0)).mean())
    stats = {"splats": len(albedo), "iterations": iterations, "saved_estimate_s": saved, "estimate_s": estimate,
             "measured_s": measured, "ratio": measured / estimate, "albedo_change": change,
             "albedo_mean": albedo.mean(axis=0).tolist(), "roughness_change": float(np.abs(rough - rough0.mean()).mean()),
             "setup_s": s.estimate_setup_s, "s_per_iter": s.estimate_s_per_iter}
    print("SAMPLE_STATS: " + json.dumps(stats), flush=True)
    h.check(change > 0.01, "albedo barely changed (%.4f)" % change)
    h.check(stats["roughness_change"] > 1e-3, "roughness unchanged")
    for name, a in (("albedo", albedo), ("roughness", rough), ("metallic", metallic)):
        h.check(np.all(np.isfinite(a)) and a.min() >= 0.0 and a.max() <= 1.0, "%s outside [0, 1]" % name)
    # The estimate against the measured time is printed, not asserted: a timed assertion fails
    # whenever the machine's load changes between the probe and the run (the house rules keep
    # speed in benchmarks). The ratio is in the SAMPLE_STATS line the test prints.
    h.check(estimate > 0.0 and measured > 0.0, "no estimate (%s) or no run (%s)" % (estimate, measured))
    world = context.scene.world
    h.check(any(n.type == "TEX_ENVIRONMENT" and n.image is not None and n.image.name == "PTIR recovered environment"
                for n in world.node_tree.nodes), "recovered environment not set")


h.run(main)
