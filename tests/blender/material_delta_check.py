"""Material edits as deltas to the persistent engine, in blender -b (run by test_material_delta.py).

    blender -b sample_blends/cornell_splats.blend ... -P material_delta_check.py -- WORK_DIR

The session of the live viewport (engine_sync) loads the Cornell splat sample; then material edits
through bpy.ops.ptir.edit_material -- the albedo of a vertex group's splats (sent by index), the
roughness of all of them, and (the display now showing the albedo, so the mesh is updated) a tint of
all albedos -- reach the engine straight from the operator (push_material_edit: one channel each,
nothing else, and nothing again on the depsgraph update's sync). The engine's image after the deltas must equal, to the last bit, the
image of a fresh engine loaded from a full export of the edited scene; and the edits must not have
re-exported anything. Prints "DELTA_STATS: {json}".
"""

import json
import math
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402

h.enable_addon()
from ptir_blender.blender import engine_sync  # noqa: E402
from ptir_blender.operators import render_engine  # noqa: E402

W = H = 48


def view():
    cam = bpy.context.scene.camera
    f = 0.5 * W / math.tan(0.5 * cam.data.angle_x)
    c2w = np.array(cam.matrix_world, np.float64)
    return {"c2w": c2w.reshape(-1).tolist(), "fx": f, "fy": f, "cx": W / 2, "cy": H / 2, "width": W, "height": H}


def render(session, name):
    path = session.file(name)  # in the session's folder: the only place its engine writes
    r = session.engine.call({"cmd": "render", "view": view(), "spp": 4, "output": path})
    h.check(r["ok"], "render: %s" % r)
    return np.fromfile(path, np.float32).reshape(H, W, 4)


def sync(session, changed=None):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return session.sync(depsgraph, render_engine.integrator_settings(bpy.context.scene.ptir_render),
                        changed=changed)


def main():
    h.argv()  # WORK_DIR: unused since each session's engine writes only in its own folder
    cli = render_engine.cli_path()
    obj = bpy.data.objects["Suzanne Splats"]
    bpy.context.view_layer.objects.active = obj
    n = len(obj.data.vertices)
    vg = obj.vertex_groups.new(name="part")
    members = list(range(0, n, 7))
    vg.add(members, 1.0, "REPLACE")

    live = engine_sync.EngineSession()
    engine_sync._SESSION = live  # the operator pushes to the module's session
    live.ensure(cli)
    h.check(sync(live)["load"], "first sync loads")
    before = render(live, "before.raw")
    sent0 = dict(live.engine.sent_bytes)
    r1 = bpy.ops.ptir.edit_material(channel="ALBEDO", operation="SET", color=(0.9, 0.05, 0.05), vertex_group="part")
    r2 = bpy.ops.ptir.edit_material(channel="ROUGHNESS", operation="SCALE", value=0.5)
    h.check(r1 == {"FINISHED"} and r2 == {"FINISHED"}, "edits: %s %s" % (r1, r2))
    # The display shows neither channel: the operator tagged no depsgraph update, so the next view_update
    # reports other objects only (here: none); it must send nothing more.
    follow = sync(live, changed=set())
    # With the display showing the albedo, an albedo edit does update the mesh; the depsgraph update's
    # sync (the object changed) must not send it again.
    obj.ptir_splat.display = "ALBEDO"
    r3 = bpy.ops.ptir.edit_material(channel="ALBEDO", operation="TINT", color=(0.5, 1.0, 1.0))
    h.check(r3 == {"FINISHED"}, "edit: %s" % r3)
    follow_shown = sync(live, changed={obj.name})
    sent = {k: v - sent0.get(k, 0) for k, v in live.engine.sent_bytes.items() if v - sent0.get(k, 0) > 0}
    after = render(live, "after.raw")

    fresh = engine_sync.EngineSession()
    fresh.ensure(cli)
    h.check(sync(fresh)["load"], "fresh session loads")
    reference = render(fresh, "reference.raw")
    stats = {"splats": n, "edited_by_index": len(members), "sent": sent, "follow_up": follow["sent"],
             "follow_up_displayed": follow_shown["sent"],
             "max_diff_vs_fresh_load": float(np.abs(after - reference).max()),
             "change_vs_before": float(np.abs(after - before).mean()), "loads": live.loads,
             "files_left": sorted(f for f in os.listdir(live.folder) if f.endswith((".f32", ".u32")))}
    print("DELTA_STATS: " + json.dumps(stats), flush=True)
    live.stop()
    fresh.stop()
    h.check(stats["loads"] == 1 and follow["sent"] == [] and follow_shown["sent"] == [],
            "an edit re-exported or re-sent: %s" % stats)
    expected = len(members) * (12 + 4) + n * 4 + n * 12  # a group's albedo + indices; all roughness; all albedo
    h.check(expected <= sent.get("splat_materials", 0) < expected + 800 and set(sent) == {"splat_materials"},
            "sent %s, expected %d bulk bytes" % (sent, expected))
    h.check(stats["change_vs_before"] > 1e-3, "the edits do not show")
    h.check(stats["max_diff_vs_fresh_load"] == 0.0, "deltas differ from a fresh load")


h.run(main)
