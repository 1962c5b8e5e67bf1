"""Import with Forward/Up axes and scale (run by test_import_axes.py):

    blender -b -P import_axes_check.py -- FILE.ply

A Y-up capture imported with Up = Y, Forward = -Z and Scale 2: the object's matrix maps the file's
+Y to Blender's +Z and its -Z to Blender's +Y, scaled by 2; world positions of the splats follow it.
The Convention presets give their axes without Forward / Up (a trainer's -Y up, +Z ahead; Y up, -Z
ahead). Make Relightable's job (no photos) writes the splats in world space and passes Blender's +Z
as their up (`--up 0,0,1`): the file's -Y, for the object imported with the trainer's convention.
"""

import os
import sys
import tempfile

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402

h.enable_addon()


def main():
    path = h.argv()[0]
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=path, axis_forward="-Z", axis_up="Y", global_scale=2.0)
    h.check(r == {"FINISHED"}, "import returned %s" % r)
    obj = bpy.context.active_object
    m = np.array(obj.matrix_world)
    up = m[:3, :3] @ np.array([0.0, 1.0, 0.0])
    fwd = m[:3, :3] @ np.array([0.0, 0.0, -1.0])
    h.check(np.allclose(up, [0, 0, 2], atol=1e-6), "file +Y -> Blender +Z x2, got %s" % up)
    h.check(np.allclose(fwd, [0, 2, 0], atol=1e-6), "file -Z -> Blender +Y x2, got %s" % fwd)
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=path)
    h.check(np.allclose(np.array(bpy.context.active_object.matrix_world), np.eye(4)), "default axes: identity")
    for preset, file_up, file_ahead in (("TRAINER", (0, -1, 0), (0, 0, 1)), ("Y_UP", (0, 1, 0), (0, 0, -1)),
                                        ("BLENDER", (0, 0, 1), (0, 1, 0))):
        r = bpy.ops.import_scene.gaussian_splat_ply(filepath=path, axis_preset=preset)
        h.check(r == {"FINISHED"}, "import (%s) returned %s" % (preset, r))
        m = np.array(bpy.context.active_object.matrix_world)[:3, :3]
        h.check(np.allclose(m @ np.array(file_up, float), [0, 0, 1], atol=1e-6), "%s: file up %s -> Blender +Z, got %s"
                % (preset, file_up, m @ np.array(file_up, float)))
        h.check(np.allclose(m @ np.array(file_ahead, float), [0, 1, 0], atol=1e-6), "%s: file ahead %s -> +Y" % (preset, file_ahead))
    # The last import stands the object up with the trainer's convention; Make Relightable's job without photos.
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=path, axis_preset="TRAINER")
    obj = bpy.context.active_object
    from ptir_blender.blender import optimize_job, splat_object
    from ptir_blender.io import splat_ply
    settings = bpy.context.scene.ptir_optimize
    settings.splat_object = obj
    job_dir = tempfile.mkdtemp()
    job = optimize_job.prepare(bpy.context, settings, job_dir, "ptir", source="SPLATS", own_defaults=True)
    k = job.args.index("--up")
    h.check(job.args[k + 1] == "0,0,1", "Make Relightable passes Blender's +Z as up, got %s" % job.args[k:k + 2])
    local = splat_object.read_data_from_object(obj).position.astype(np.float64)
    world = splat_ply.read_splat_ply(os.path.join(job_dir, "splats.ply")).position.astype(np.float64)
    h.check(np.allclose(world[:, 2], -local[:, 1], atol=1e-5), "the splats go out with the file's -Y as world +Z")


h.run(main)
