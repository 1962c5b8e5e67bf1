"""The plush dog through the add-on's Optimise panel in blender -b (run by test_addon_real_capture.py).

    blender -b ... -P addon_real_capture_check.py -- CAPTURE_DIR PLY WORK_DIR

Imports the user's PLY, points the Optimise panel at the capture folder and optimises with short
settings: the geometry stage (`ptir fit`) and the inversion both measure the capture against the splats
(the object's coverage masks the photos), the panel learns the subject, the results come back onto the
splats. Prints "REAL_CAPTURE: {json}".
"""

import json
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402

h.enable_addon()
from ptir_blender.blender import optimize_job, splat_object  # noqa: E402


def main():
    capture, ply, work = h.argv()[:3]
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=ply)
    h.check(r == {"FINISHED"}, "import")
    splats = bpy.context.active_object
    s = bpy.context.scene.ptir_optimize
    s.source = "DATASET"
    s.dataset_dir = capture
    s.splat_object = splats
    s.fit_iterations, s.iterations, s.spp, s.crop, s.bounces = 30, 2, 1, 64, 1
    s.output_dir = os.path.join(work, "out")
    os.makedirs(os.path.join(work, "job"), exist_ok=True)
    job = optimize_job.prepare(bpy.context, s, os.path.join(work, "job"), os.environ["PTIR_CLI"],
                               out_dir=s.output_dir)
    stats = {"fit_stage": bool(job.fit_args)}
    before = splat_object.read_data_from_object(splats).albedo.copy()
    r = bpy.ops.ptir.optimize()
    h.check(r == {"FINISHED"}, "optimise: %s" % s.status)
    stats["subject"] = s.capture_subject
    after = splat_object.read_data_from_object(splats).albedo
    stats["albedo_changed"] = float(np.abs(after - before).mean())
    with open(os.path.join(s.output_dir, "settings.json")) as f:
        stats["cli_subject"] = json.load(f)["capture"]["subject"]
    # The geometry stage (`ptir fit`) masked the photos by the splat's coverage: it grew no blobs.
    with open(os.path.join(s.output_dir, "fit", "capture", "calibration.json")) as f:
        stats["fit_subject"] = json.load(f)["subject"]
    print("REAL_CAPTURE: " + json.dumps(stats), flush=True)


h.run(main)
