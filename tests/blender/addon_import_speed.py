"""Times File > Import > Gaussian Splats on a 1M-splat SH-degree-3 PLY (run by test_addon_io.py).

    blender -b ... -P addon_import_speed.py -- FILE.ply

Prints "IMPORT_SPEED: {json}" with wall and CPU seconds of the operator (reading + building the
object with its attributes and display modifier) and of the first depsgraph evaluation.
"""

import json
import os
import sys
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402

h.enable_addon()


def main():
    path = h.argv()[0]
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    t0, c0 = time.perf_counter(), time.process_time()
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=path)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    h.check(r == {"FINISHED"}, "import returned %s" % r)
    obj = bpy.context.active_object
    n = len(obj.data.vertices)
    t1 = time.perf_counter()
    bpy.context.view_layer.update()
    dg = bpy.context.evaluated_depsgraph_get()
    shown = sum(1 for i in dg.object_instances if i.is_instance)
    display = time.perf_counter() - t1
    print("IMPORT_SPEED: " + json.dumps({"splats": n, "wall_s": round(wall, 3), "cpu_s": round(cpu, 3),
                                         "display_eval_s": round(display, 3), "instances_shown": shown,
                                         "attributes": len(obj.data.attributes)}), flush=True)


h.run(main)
