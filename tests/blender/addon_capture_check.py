"""Blender side of test_addon_capture.py.

    blender -b ... -P addon_capture_check.py -- SPEC.json WORK_DIR

1. bpy.ops.ptir.import_capture_cameras on the COLMAP folder: one camera per photo in the
   "PTIR Capture Cameras" collection, the photo (the undistorted copy) as its background image,
   the pose the capture was made with, and a projection that matches COLMAP's OPENCV formula
   (numpy, scripts/dataset/layouts.py) on the distorted photo: a world point seen through the
   Blender camera (world_to_camera_view: lens, sensor, shift, resolution) lands on the undistorted
   pixel whose lens-distorted position is where COLMAP projects the point, less the crop origin.
2. bpy.ops.ptir.optimize with the COLMAP folder as the dataset: finishes, writes the albedo back.
3. The same with the splat object moved: the views come through `ptir cameras` and follow it
   (the recovered albedo is that of 2).
Prints "CAPTURE_STATS: {json}".
"""

import json
import os
import sys

import bpy
import numpy as np
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402

h.enable_addon()
from ptir_blender.blender import splat_object  # noqa: E402
from dataset import capture, layouts  # noqa: E402  (scripts/, on the path through the harness)


def check_cameras(spec, stats):
    r = bpy.ops.ptir.import_capture_cameras(directory=spec["colmap"], split="all")
    h.check(r == {"FINISHED"}, "import cameras")
    coll = bpy.data.collections["PTIR Capture Cameras"]
    cams = sorted(coll.objects, key=lambda o: o.name)
    stats["cameras"] = len(cams)
    scene = bpy.context.scene
    w, hgt = scene.render.resolution_x, scene.render.resolution_y
    f, size = spec["f"], spec["size"]
    params = [f, f, size / 2, size / 2] + spec["distortion"]
    worst = 0.0
    pts = np.array([[0.0, 0.0, 0.6], [0.3, -0.2, 0.9], [-0.25, 0.2, 0.4]])
    for i, obj in enumerate(cams):
        h.check(obj.name == "r_%d" % i, "camera names: %s" % obj.name)
        bg = obj.data.background_images
        h.check(obj.data.show_background_images and len(bg) == 1 and bg[0].image is not None, "background photo")
        h.check(os.path.isfile(bpy.path.abspath(bg[0].image.filepath)), "photo file exists")
        h.check(tuple(bg[0].image.size) == (w, hgt), "photo size %s vs render %dx%d" % (tuple(bg[0].image.size), w, hgt))
        m = np.array(obj.matrix_world)
        h.check(np.allclose(m, np.array(spec["cameras"][i]), atol=1e-5), "camera %d pose" % i)
        R, t = capture.w2c_from_opengl(m)
        uv_colmap = layouts.project("OPENCV", params, R, t, pts)
        # The undistorted image is a window of the pinhole image: its origin (x0, y0) in pixels.
        x0 = size / 2 - (0.5 * w - obj.data.shift_x * max(w, hgt))
        y0 = size / 2 - (0.5 * hgt + obj.data.shift_y * max(w, hgt))
        for p, uvc in zip(pts, uv_colmap):
            v = world_to_camera_view(scene, obj, Vector(p))
            u_px, v_px = v.x * w + x0, (1.0 - v.y) * hgt + y0  # in the uncropped pinhole image
            xd, yd = layouts.distort("OPENCV", params, np.array((u_px - size / 2) / f), np.array((v_px - size / 2) / f))
            worst = max(worst, abs(float(xd) * f + size / 2 - uvc[0]), abs(float(yd) * f + size / 2 - uvc[1]))
            h.check(abs(x0 - round(x0)) < 1e-4 and abs(y0 - round(y0)) < 1e-4, "whole-pixel window origin")
    stats["max_projection_error_px"] = worst


def optimise(spec, work, splats, name):
    s = bpy.context.scene.ptir_optimize
    s.source = "DATASET"
    s.dataset_dir = spec["colmap"]
    s.splat_object = splats
    s.iterations, s.spp, s.bounces = 15, 2, 1
    s.env, s.env_width, s.env_height = "latlong", 16, 8
    s.learn_exposure = True
    # Per-splat albedo compared across runs: the geometry stage (on by default for a COLMAP folder)
    # would change the splats; addon_fit_check.py tests it.
    s.fit_geometry = "OFF"
    s.output_dir = os.path.join(work, name)
    # A sentinel albedo the optimiser never starts from (it starts at 0.3): a result that lands
    # in the object differs from it everywhere.
    before = np.full_like(splat_object.read_data_from_object(splats).albedo, 0.77)
    splat_object.write_material_attributes(splats.data, albedo=before)
    r = bpy.ops.ptir.optimize()
    h.check(r == {"FINISHED"}, "optimise (%s): %s" % (name, s.status))
    h.check(os.path.isfile(os.path.join(s.output_dir, "exposure.json")), "Learn Exposure reaches the engine")
    after = splat_object.read_data_from_object(splats).albedo
    h.check(np.abs(after - before).max() > 0.01, "albedo written back (%s)" % name)
    return after.copy()


def main():
    spec, work, splats = h.spec_scene_with_splats()
    stats = {}
    check_cameras(spec, stats)
    a = optimise(spec, work, splats, "identity")
    splats.location = (0.5, -0.25, 0.1)
    bpy.context.view_layer.update()
    b = optimise(spec, work, splats, "moved")
    # The moved views are the capture's, carried along: the same problem, the same answer (float rounding).
    stats["albedo_moved_vs_identity_max"] = float(np.abs(a - b).max())
    stats["albedo_moved_vs_identity_mean"] = float(np.abs(a - b).mean())
    stats["albedo_change_mean"] = float(np.abs(a - 0.3).mean())
    h.check(stats["albedo_moved_vs_identity_mean"] < 0.1 * stats["albedo_change_mean"],
            "moved object: views follow it (%s)" % stats)
    print("CAPTURE_STATS: " + json.dumps(stats), flush=True)


h.run(main)
