"""Import with Forward/Up axes and scale (run by test_import_axes.py):

    blender -b -P import_axes_check.py -- FILE.ply

A Y-up capture imported with Up = Y, Forward = -Z and Scale 2: the object's matrix maps the file's
+Y to Blender's +Z and its -Z to Blender's +Y, scaled by 2; world positions of the splats follow it.
"""

import os
import sys

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


h.run(main)
