"""Material edits as deltas to the persistent engine, in blender -b (run by test_material_delta.py).

    blender -b sample_blends/cornell_splats.blend ... -P material_delta_check.py -- WORK_DIR

The session of the live viewport (engine_sync) loads the Cornell splat sample; then material edits
through bpy.ops.ptir.edit_material -- the albedo of a vertex group's splats (sent by index), the
roughness of all of them -- reach the engine straight from the operator (push_material_edit: one
channel each, nothing else). The engine's image after the deltas must equal, to the last bit, the
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


def render(session, path):
    r = session.engine.call({"cmd": "render", "view": view(), "spp": 4, "output": path})
    h.check(r["ok"], "render: %s" % r)
    return np.fromfile(path, np.float32).reshape(H, W, 4)


def sync(session):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return session.sync(depsgraph, render_engine.integrator_settings(bpy.context.scene.ptir_render))


def main():
    work = h.argv()[0]
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
    before = render(live, os.path.join(work, "before.raw"))
    sent0 = dict(live.engine.sent_bytes)
    r1 = bpy.ops.ptir.edit_material(channel="ALBEDO", operation="SET", color=(0.9, 0.05, 0.05), vertex_group="part")
    r2 = bpy.ops.ptir.edit_material(channel="ROUGHNESS", operation="SCALE", value=0.5)
    h.check(r1 == {"FINISHED"} and r2 == {"FINISHED"}, "edits: %s %s" % (r1, r2))
    follow = sync(live)  # what the depsgraph update would bring: nothing more to send
    sent = {k: v - sent0.get(k, 0) for k, v in live.engine.sent_bytes.items() if v - sent0.get(k, 0) > 0}
    after = render(live, os.path.join(work, "after.raw"))

    fresh = engine_sync.EngineSession()
    fresh.ensure(cli)
    h.check(sync(fresh)["load"], "fresh session loads")
    reference = render(fresh, os.path.join(work, "reference.raw"))
    stats = {"splats": n, "edited_by_index": len(members), "sent": sent, "follow_up": follow["sent"],
             "max_diff_vs_fresh_load": float(np.abs(after - reference).max()),
             "change_vs_before": float(np.abs(after - before).mean()), "loads": live.loads,
             "files_left": sorted(f for f in os.listdir(live.folder) if f.endswith((".f32", ".u32")))}
    print("DELTA_STATS: " + json.dumps(stats), flush=True)
    live.stop()
    fresh.stop()
    h.check(stats["loads"] == 1 and follow["sent"] == [], "an edit re-exported or re-sent: %s" % stats)
    expected = (len(members) * (12 + 4) + n * 4)  # albedo + index per group member; roughness of all
    h.check(expected <= sent.get("splat_materials", 0) < expected + 600 and set(sent) == {"splat_materials"},
            "sent %s, expected %d bulk bytes" % (sent, expected))
    h.check(stats["change_vs_before"] > 1e-3, "the edits do not show")
    h.check(stats["max_diff_vs_fresh_load"] == 0.0, "deltas differ from a fresh load")


h.run(main)
