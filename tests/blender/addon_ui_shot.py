"""The add-on in a real Blender window (Xvfb): the PTIR sidebar during a modal optimisation, Esc, undo,
and the screenshot for the README (docs/addon_panel.png).

    xvfb-run -a -s "-screen 0 1280x800x24" blender --factory-startup --enable-event-simulate \
        sample_blends/cornell_splats.blend -P tests/blender/addon_ui_shot.py -- OUT.png WORKDIR

Steps (bpy.app.timers, simulated input events):
  1. a training set from the sample scene itself: the scene exported by the add-on and rendered by
     the CLI from four cameras around the splats (48 x 48)
  2. the 3D viewport in camera view with Material Preview shading (the splat display), the sidebar
     open on the PTIR tab (Ctrl+Wheel over the tabs, as a user would), Render Properties shown
  3. bpy.ops.ptir.optimize('INVOKE_DEFAULT'): modal; after a few timer ticks the panel shows the
     iteration, loss and ETA -> screenshot
  4. Esc (a simulated key press) cancels: the operator ends, the splat attributes are unchanged
  5. undo: a material edit through the operator, then Edit > Undo restores the albedo
Prints "UI_CHECK: {json}" and quits; exits 1 on a failure. The Python threads during the run and at the
end are listed: the add-on must start none (io/pipe_lines.py says why; a reader thread of its own made
this script's bpy.ops.ed.undo_push crash Blender one run in four).
"""

import json
import math
import os
import subprocess
import sys
import threading
import traceback

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402

h.enable_addon()
from ptir_blender.blender import scene_bridge, splat_object  # noqa: E402
from ptir_blender.io import dataset_file  # noqa: E402
from ptir_blender.operators import render_engine  # noqa: E402

OUT, WORK = h.argv()[0], h.argv()[1]
STATE = {"step": 0, "ticks": 0, "result": {}}


fail = h.gui_fail


def window_parts():
    win, view3d = h.window_and_view3d()
    props = next((a for a in win.screen.areas if a.type == "PROPERTIES"), None)
    return win, view3d, props


def make_training_set():
    """Renders the sample scene from four cameras around the splats with the CLI (the ground truth is
    the scene itself), writing WORK/dataset/transforms_train.json + images."""
    folder = os.path.join(WORK, "dataset")
    os.makedirs(os.path.join(folder, "train"), exist_ok=True)
    scene_json, _ = scene_bridge.export_engine_scene(bpy.context, os.path.join(WORK, "gt"))
    doc = json.load(open(scene_json))
    target = np.array(bpy.data.objects["Suzanne Splats"].matrix_world.translation)
    frames = []
    for i in range(4):
        a = math.radians(-90 + (i - 1.5) * 25)
        eye = target + np.array([1.4 * math.cos(a), 1.4 * math.sin(a), 0.35])
        z = eye - target
        z /= np.linalg.norm(z)
        x = np.cross((0, 0, 1), z)
        x /= np.linalg.norm(x)
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, np.cross(z, x), z, eye
        doc["cameras"] = [{"name": "v%d" % i, "transform": m.tolist(), "fov_x": 0.7, "width": 48, "height": 48}]
        with open(scene_json, "w") as f:
            json.dump(doc, f)
        out = os.path.join(folder, "train", "v%d.png" % i)
        r = subprocess.run([render_engine.cli_path(), "render", scene_json, "-o", out, "--spp", "32", "-q"],
                           capture_output=True, text=True)
        if r.returncode != 0:
            fail("dataset render: %s" % r.stderr)
        frames.append({"file_path": "./train/v%d" % i, "transform_matrix": m.tolist()})
    with open(os.path.join(folder, "transforms_train.json"), "w") as f:
        json.dump({"camera_angle_x": 0.7, "frames": frames}, f)
    dataset_file.read_transforms(os.path.join(folder, "transforms_train.json"))
    return folder


def albedo(obj):
    return splat_object.read_material_attributes(obj.data)[0].copy()


def step():
    try:
        return _step()
    except Exception:
        traceback.print_exc()
        fail("exception in step %d" % STATE["step"])


def _step():
    s = STATE
    win, view3d, props = window_parts()
    scene = bpy.context.scene
    obj = bpy.data.objects["Suzanne Splats"]
    if s["step"] == 0:
        s["dataset"] = make_training_set()
        space = view3d.spaces.active
        space.show_region_ui = True
        space.shading.type = "MATERIAL"
        space.region_3d.view_perspective = "CAMERA"
        if props is not None:
            props.spaces.active.context = "RENDER"
        o = scene.ptir_optimize
        o.source, o.dataset_dir, o.splat_object = "DATASET", s["dataset"], obj
        o.iterations, o.spp, o.bounces, o.env_width, o.env_height = 300, 4, 1, 32, 16
        o.fit_geometry = "OFF"  # the materials alone: the shots compare each splat's albedo before and after
        o.optimize_meshes, o.write_environment = False, True
        bpy.context.view_layer.objects.active = obj  # active (the panels follow it), not selected:
        for o in bpy.context.view_layer.objects:     # no selection outline on the splat display
            o.select_set(False)
        s["albedo0"] = albedo(obj)
        s["step"] = 1
        return 1.0
    if s["step"] == 1:
        # Sidebar tab: hover over the sidebar and Ctrl+Wheel through the tabs to the last one (PTIR).
        region = next(r for r in view3d.regions if r.type == "UI")
        x, y = region.x + region.width - 8, region.y + region.height // 2
        win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
        for _ in range(6):
            win.event_simulate(type="WHEELDOWNMOUSE", value="PRESS", x=x, y=y, ctrl=True)
        s["step"] = 2
        return 0.5
    if s["step"] == 2:
        with bpy.context.temp_override(window=win, area=view3d,
                                       region=next(r for r in view3d.regions if r.type == "WINDOW")):
            r = bpy.ops.ptir.optimize("INVOKE_DEFAULT")
        if r != {"RUNNING_MODAL"}:
            fail("optimize did not start modally: %s" % r)
        s["step"] = 3
        return 0.5
    if s["step"] == 3:
        o = scene.ptir_optimize
        s["ticks"] += 1
        if not o.running:
            fail("the optimisation ended before the screenshot: %s" % o.status)
        if (o.status.startswith("iteration") and s["ticks"] >= 6) or s["ticks"] > 240:
            s["result"]["status_during_run"] = o.status
            s["result"]["threads_during_run"] = sorted(t.name for t in threading.enumerate())
            for area in win.screen.areas:
                area.tag_redraw()
            s["step"] = 4
            return 0.5
        return 0.25
    if s["step"] == 4:
        with bpy.context.temp_override(window=win):
            bpy.ops.screen.screenshot(filepath=OUT)
        s["result"]["screenshot"] = OUT
        # Esc, as the user presses it, over the 3D viewport.
        region = next(r for r in view3d.regions if r.type == "WINDOW")
        win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=region.x + 100, y=region.y + 100)
        win.event_simulate(type="ESC", value="PRESS", x=region.x + 100, y=region.y + 100)
        win.event_simulate(type="ESC", value="RELEASE", x=region.x + 100, y=region.y + 100)
        s["step"] = 5
        return 0.5
    if s["step"] == 5:
        o = scene.ptir_optimize
        if o.running:
            s["ticks"] += 1
            if s["ticks"] > 400:
                fail("Esc did not stop the optimisation")
            return 0.25
        s["result"]["status_after_esc"] = o.status
        if o.status != "cancelled":
            fail("status after Esc: %s" % o.status)
        if not np.array_equal(albedo(obj), s["albedo0"]):
            fail("a cancelled optimisation changed the splats")
        # Undo of a material edit.
        with bpy.context.temp_override(window=win, area=view3d,
                                       region=next(r for r in view3d.regions if r.type == "WINDOW")):
            # A button press runs the operator and then pushes its undo step ("Apply Material Edit");
            # operators called from Python skip that push, so it is done here as the window manager would.
            bpy.ops.ed.undo_push(message="before edit")
            r = bpy.ops.ptir.edit_material(channel="ALBEDO", operation="SET", color=(0.0, 0.0, 1.0))
            bpy.ops.ed.undo_push(message="Apply Material Edit")
            edited = albedo(obj)
            bpy.ops.ed.undo()
        obj = bpy.data.objects["Suzanne Splats"]
        restored = albedo(obj)
        s["result"]["undo"] = bool(np.allclose(edited, (0, 0, 1)) and np.array_equal(restored, s["albedo0"]))
        if r != {"FINISHED"} or not s["result"]["undo"]:
            fail("undo of a material edit: edited %s restored %s" % (edited[0], restored[0]))
        s["result"]["threads_at_end"] = sorted(t.name for t in threading.enumerate())
        print("UI_CHECK: " + json.dumps(s["result"]), flush=True)
        print("ADDON_CHECK: OK", flush=True)
        bpy.ops.wm.quit_blender()
        return None
    return None


bpy.app.timers.register(step, first_interval=2.0)
