"""Blender side of test_addon_capture.py's geometry-stage test: the fit step of the optimise flow.

    blender -b ... -P addon_fit_check.py -- SPEC.json WORK_DIR

1. When the flow fits (Fit Geometry = Auto): a COLMAP folder yes; the NeRF-layout folder of the same
   views and Scene Cameras no; On and Off as set.
2. Cancel during the fit (a long fit, bpy.ops.ptir.optimize blocking; request_cancel from a timer,
   as Esc / the Cancel button do): CANCELLED, the object's splats and albedo unchanged.
3. Optimise from the COLMAP folder with the default Auto: `ptir fit` then `ptir optimize`; the fitted
   PLY lies in OUTPUT/fit/, the object's splats are replaced by it (count and positions), the albedo
   is written back, the fit lowered the loss (the same six views in its first and last epochs), and the
   inversion took its bounce light from the fitted splats' SH (`--indirect field`).
4. The same with the object moved: the object's local splats are the fitted (world-space) PLY
   brought back through the inverse of its transform.
5. The time presets: Draft gives the fit `--budget` of FIT_SHARE of its 2 minutes and the inversion
   the rest with no iteration count (and the engine's automatic batch), re-counted at its launch from
   what the fit left; Custom keeps `--iters` /
   `--spp` / `--crop` and no budget.
Prints "FIT_STATS: {json}".
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
from ptir_blender.blender import optimize_job, splat_object  # noqa: E402
from ptir_blender.io import splat_ply  # noqa: E402
from ptir_blender.operators import optimize_ops  # noqa: E402

VIEWS = 6
FIT_ITERS = 150
# The photos show a floor the splats (a sphere) do not hold: the loss cannot fall far.
LOSS_RATIO_MAX = 0.9


def settings(spec, splats, out, fit_iterations):
    s = bpy.context.scene.ptir_optimize
    s.source = "DATASET"
    s.dataset_dir = spec["colmap"]
    s.splat_object = splats
    s.fit_geometry = "AUTO"
    s.fit_iterations = fit_iterations
    s.iterations, s.spp, s.bounces = 5, 2, 1
    s.env, s.env_width, s.env_height = "latlong", 16, 8
    s.output_dir = out
    return s


def check_decisions(spec):
    s = bpy.context.scene.ptir_optimize
    nerf = os.path.dirname(spec["input"])
    h.check(os.path.isfile(os.path.join(nerf, "transforms_train.json")), "the NeRF folder of the views")
    s.source, s.fit_geometry = "DATASET", "AUTO"
    h.check(optimize_job.wants_fit(s, spec["colmap"], "train"), "Auto fits a COLMAP capture")
    h.check(optimize_job.wants_fit(s, nerf, "train"), "Auto fits a NeRF-layout folder")
    h.check(not optimize_job.wants_fit(s, nerf, "train", has_meshes=True), "Auto does not fit one with scene meshes")
    h.check(optimize_job.wants_fit(s, spec["colmap"], "train", has_meshes=True), "Auto fits a capture with meshes")
    s.fit_geometry = "OFF"
    h.check(not optimize_job.wants_fit(s, spec["colmap"], "train"), "Off")
    s.fit_geometry, s.source = "ON", "CAMERAS"
    h.check(optimize_job.wants_fit(s, None, "train"), "On")
    s.fit_geometry = "AUTO"
    h.check(not optimize_job.wants_fit(s, None, "train"), "Auto does not fit Scene Cameras")


def snapshot(obj):
    d = splat_object.read_data_from_object(obj)
    return d.position.copy(), d.albedo.copy()


def cancel_during_fit(spec, splats, work, stats):
    s = settings(spec, splats, os.path.join(work, "cancelled"), 1000000)
    pos, alb = snapshot(splats)
    timer = threading.Timer(3.0, optimize_ops.request_cancel)
    timer.start()
    t0 = time.time()
    r = bpy.ops.ptir.optimize()
    stats["cancel_seconds"] = time.time() - t0
    timer.cancel()
    h.check(r == {"CANCELLED"}, "a cancelled fit returns CANCELLED (%s, %s)" % (r, s.status))
    h.check(s.status == "cancelled", "status after cancel: %s" % s.status)
    h.check(stats["cancel_seconds"] < 60, "cancelled promptly (%.1f s)" % stats["cancel_seconds"])
    pos2, alb2 = snapshot(splats)
    h.check(pos2.shape == pos.shape and np.array_equal(pos2, pos) and np.array_equal(alb2, alb),
            "a cancelled fit changed the splats")


def epoch_losses(log_path):
    rows = [l.split(",") for l in open(log_path).read().splitlines()[1:]]
    loss = np.array([float(r[2]) for r in rows])  # the image term (the recolouring has no distortion term)
    return float(loss[:VIEWS].mean()), float(loss[-VIEWS:].mean()), len(rows)


def fit_and_optimise(spec, splats, work, name, stats):
    out = os.path.join(work, name)
    s = settings(spec, splats, out, FIT_ITERS)
    n0 = len(splats.data.vertices)
    before = np.full((n0, 3), 0.77, np.float32)  # a sentinel albedo the optimiser never starts from
    splat_object.write_material_attributes(splats.data, albedo=before)
    r = bpy.ops.ptir.optimize()
    h.check(r == {"FINISHED"}, "optimise with the fit (%s): %s" % (name, s.status))
    fitted_path = os.path.join(out, "fit", "gaussians.ply")
    h.check(os.path.isfile(fitted_path), "the fitted PLY beside the output (%s)" % fitted_path)
    fitted = splat_ply.read_splat_ply(fitted_path)
    d = splat_object.read_data_from_object(splats)
    h.check(len(d) == len(fitted), "the object holds the fitted splats (%d vs %d)" % (len(d), len(fitted)))
    # A capture is read in the object's own frame, moved or not (optimize_job.prepare): the fitted PLY holds
    # the object's own coordinates.
    err = float(np.abs(d.position.astype(np.float64) - fitted.position).max())
    h.check(err < 1e-4, "object splats = the fitted PLY in the object's own frame (max %.2g)" % err)
    h.check(np.abs(d.albedo - 0.77).max() > 0.01, "albedo written back (%s)" % name)
    first, last, rows = epoch_losses(os.path.join(out, "fit", "log.csv"))
    recolour = os.path.join(out, "fit", "recolour", "log.csv")
    if os.path.isfile(recolour):
        # A trained splat on real photos (pipeline/trained_fit.h): half its colours refitted on its own
        # geometry (fit/recolour/), half refined from there (fit/).
        first, _, recoloured_rows = epoch_losses(recolour)
        rows += recoloured_rows
    h.check(rows == FIT_ITERS, "the fit ran its %d iterations (%d)" % (FIT_ITERS, rows))
    h.check(last < LOSS_RATIO_MAX * first, "the fit lowered the loss (%.4f -> %.4f)" % (first, last))
    h.check("fitted from %d" % n0 in s.status, "status names the fit: %s" % s.status)
    # After its fit the flow takes the bounce light from the fitted splats' SH (`--indirect field`):
    # the inversion's checkpoint names it among its settings.
    ckpt = open(os.path.join(out, "checkpoint.bin"), "rb").read()
    h.check(b"indirect" in ckpt and b"field" in ckpt, "the inversion took its bounce light from the fitted splats")
    stats[name] = {"splats_before": n0, "splats_after": len(d), "loss_first_epoch": first,
                   "loss_last_epoch": last, "position_error": err}


def check_presets(spec, splats, work):
    s = settings(spec, splats, os.path.join(work, "preset"), FIT_ITERS)
    cli = os.environ.get("PTIR_CLI", "ptir")
    for d in ("preset_job", "preset_job2"):
        os.makedirs(os.path.join(work, d), exist_ok=True)
    try:
        s.preset = "DRAFT"
        job = optimize_job.prepare(bpy.context, s, os.path.join(work, "preset_job"), cli)
        fit_budget = job.fit_args[job.fit_args.index("--budget") + 1]
        h.check(fit_budget == "%.0fs" % (optimize_job.FIT_SHARE * 120), "Draft: the fit's budget (%s)" % fit_budget)
        h.check(job.args[job.args.index("--budget") + 1] == "%.0fs" % ((1 - optimize_job.FIT_SHARE) * 120)
                and "--iters" not in job.args and "--crop" not in job.args,
                "Draft: the inversion's budget, no count, the engine's batch: %s" % job.args)
        # Launched after a fit that took 20 s, the inversion gets the 100 s the preset has left.
        late = optimize_job.inversion_args(job, 20.0)
        h.check(late[late.index("--budget") + 1] == "100s" and late[:late.index("--budget")] == job.args[:job.args.index("--budget")],
                "Draft after a 20-s fit: the inversion's budget is what is left (%s)" % late)
        s.preset = "CUSTOM"
        job = optimize_job.prepare(bpy.context, s, os.path.join(work, "preset_job2"), cli)
        h.check("--budget" not in job.args + job.fit_args and job.args[job.args.index("--iters") + 1] == "5",
                "Custom: the iteration count, no budget: %s" % job.args)
    finally:
        s.preset = "CUSTOM"


def main():
    spec, work, splats = h.spec_scene_with_splats()
    stats = {}
    check_decisions(spec)
    check_presets(spec, splats, work)
    cancel_during_fit(spec, splats, work, stats)
    fit_and_optimise(spec, splats, work, "identity", stats)
    splats.location = (0.5, -0.25, 0.1)
    splats.rotation_euler = (0.0, 0.0, 0.3)
    bpy.context.view_layer.update()
    fit_and_optimise(spec, splats, work, "moved", stats)
    print("FIT_STATS: " + json.dumps(stats), flush=True)


h.run(main)
