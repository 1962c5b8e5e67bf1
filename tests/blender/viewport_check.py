"""The live PTIR viewport in a real Blender window (Xvfb), run by test_viewport.py and bench/bench_viewport.py.

    xvfb-run -a -s "-screen 0 1280x800x24" blender --factory-startup sample_blends/cornell_splats.blend \
        -P tests/blender/viewport_check.py -- WORKDIR [--samples N] [--pixel-size P] [--no-kill] [--overlays]

Steps (bpy.app.timers; each waits until the viewport has accumulated its samples):
  missing  first with the add-on's engine path pointing nowhere: the viewport says the engine is
           unavailable (and Blender carries on); the path restored, the next redraw renders
  base     Viewport Shading > Rendered with the PTIR engine, camera view -> screenshot base.png
  albedo   the splats' albedo set to red (bpy.ops.ptir.edit_material)   -> albedo.png
  lights   both lights' power and the world strength doubled             -> lights.png
  camera   the view orbited a little (a camera move)                     -> camera.png
  move     the splat object moved 0.15 m along x (an object transform)  -> move.png
  kill     the engine process killed (SIGKILL) while a pass is running; Blender keeps running, the
           viewport says the engine died, the next redraw starts a new one -> restarted.png
  f12      F12 (bpy.ops.render.render) at 64 x 64, 8 spp through the same process: nothing is
           re-exported (no "load"); the image is saved as f12.exr beside the scene exported for the
           CLI (cli_scene/scene.json), which the pytest side renders with `ptir render` and compares
Each step records the seconds from the edit to the first pixels of the new state, the requests and
bytes the add-on sent for it (engine_process.sent_bytes), and whether the scene was reloaded.
Prints "VIEWPORT_CHECK: {json}" and quits; exits 1 on a failure.
"""

import json
import math
import os
import signal
import sys
import time
import traceback

import bpy
import numpy as np
import mathutils

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402

h.enable_addon()
from ptir_blender.blender import engine_sync, viewport_render  # noqa: E402

ARGS = h.argv()
WORK = ARGS[0]
SAMPLES = int(ARGS[ARGS.index("--samples") + 1]) if "--samples" in ARGS else 4
PIXEL = int(ARGS[ARGS.index("--pixel-size") + 1]) if "--pixel-size" in ARGS else 4
KILL = "--no-kill" not in ARGS
OVERLAYS = "--overlays" in ARGS  # keep the overlays (the status text) in the screenshots
TIMEOUT = 60.0
STEPS = ["base", "albedo", "lights", "camera", "move"] + (["kill", "restarted"] if KILL else []) + ["film"]
S = {"i": 0, "t_edit": None, "result": {"steps": {}}, "phase": "start", "sent_before": {}}


fail = h.gui_fail
parts = h.window_and_view3d


def viewport():
    vrs = list(viewport_render._active)
    return vrs[0] if vrs else None


def sent():
    e = engine_sync.session().engine
    return dict(e.sent_bytes) if e is not None else {}


def screenshot(name):
    win, view3d = parts()
    path = os.path.join(WORK, name + ".png")
    with bpy.context.temp_override(window=win, area=view3d):
        bpy.ops.screen.screenshot_area(filepath=path)
    return path


def edit(step):
    """Applies the edit of a step; returns nothing (the viewport restarts through view_update)."""
    scene = bpy.context.scene
    win, view3d = parts()
    if step == "albedo":
        obj = bpy.data.objects["Suzanne Splats"]
        bpy.context.view_layer.objects.active = obj
        with bpy.context.temp_override(window=win, area=view3d, active_object=obj, object=obj):
            r = bpy.ops.ptir.edit_material(channel="ALBEDO", operation="SET", color=(0.9, 0.02, 0.02))
        if r != {"FINISHED"}:
            fail("edit_material returned %s" % r)
    elif step == "lights":
        for light in bpy.data.lights:
            light.energy *= 2.0
        bg = scene.world.node_tree.nodes["Background"]
        bg.inputs["Strength"].default_value *= 2.0
    elif step == "camera":
        rv3d = view3d.spaces.active.region_3d
        rv3d.view_perspective = "PERSP"
        q = rv3d.view_rotation.copy()
        q.rotate(mathutils.Euler((0.0, 0.0, math.radians(8.0))))
        rv3d.view_rotation = q
    elif step == "move":
        bpy.data.objects["Suzanne Splats"].location.x += 0.15
    elif step == "film":
        scene.render.film_transparent = True  # the world seen directly leaves the picture (docs/alpha.md)
    elif step == "kill":
        vr = viewport()
        engine = engine_sync.session().engine
        S["killed_pid"] = engine.proc.pid
        os.kill(engine.proc.pid, signal.SIGKILL)
        S["result"]["pending_when_killed"] = vr.pending is not None


def f12():
    """F12 through the persistent process; returns what the pytest side compares with the CLI."""
    from ptir_blender.blender import scene_bridge
    from ptir_blender.operators import render_engine
    scene = bpy.context.scene
    scene.render.resolution_percentage = 25
    s = scene.ptir_render
    s.spp, s.seed, s.aov_passes = 8, 5, True
    session = engine_sync.session()
    loads, pid = session.loads, session.engine.proc.pid
    before = sent()
    # The compositor sees the AOV passes: Render Layers > Depth into a Viewer node.
    scene.use_nodes = True
    tree = scene.node_tree
    rl = next((n for n in tree.nodes if n.type == "R_LAYERS"), None) or tree.nodes.new("CompositorNodeRLayers")
    viewer = tree.nodes.new("CompositorNodeViewer")
    bpy.ops.render.render()
    outputs = [o.name for o in rl.outputs if o.enabled]
    tree.links.new(rl.outputs["Depth"], viewer.inputs[0])
    bpy.ops.render.render()
    vimg = bpy.data.images["Viewer Node"]
    depth = np.empty(vimg.size[0] * vimg.size[1] * 4, np.float32)
    vimg.pixels.foreach_get(depth)
    out = os.path.join(WORK, "f12.exr")
    settings = scene.render.image_settings
    settings.file_format, settings.color_depth, settings.color_mode = "OPEN_EXR", "32", "RGBA"
    bpy.data.images["Render Result"].save_render(out)
    result = bpy.data.images["Render Result"]
    folder = os.path.join(WORK, "cli_scene")
    scene_json, _ = scene_bridge.export_engine_scene(bpy.context, folder,
                                                     integrator=render_engine.integrator_settings(s))
    layer = scene.view_layers[0]
    return {"exr": out, "scene": scene_json, "camera": scene.camera.name, "spp": s.spp, "seed": s.seed,
            "bounces": s.bounces, "reloaded": session.loads != loads, "same_process": session.engine.proc.pid == pid,
            "sent_bytes": {k: v - before.get(k, 0) for k, v in sent().items() if v - before.get(k, 0) > 0},
            "render_result_size": list(result.size), "layer": layer.name, "passes": outputs,
            "depth_hit_fraction": float((depth[0::4] > 0).mean()),
            "depth_median": float(np.median(depth[0::4][depth[0::4] > 0])) if (depth[0::4] > 0).any() else 0.0,
            "depth_max": float(depth[0::4].max())}


def tick():
    try:
        return _tick()
    except Exception:
        traceback.print_exc()
        fail("exception in the check")


def _tick():
    scene = bpy.context.scene
    win, view3d = parts()
    if S["phase"] == "start":
        scene.render.engine = "PTIR"
        scene.view_settings.view_transform = "Standard"
        scene.view_settings.look = "None"
        scene.render.dither_intensity = 0.0     # 8-bit screenshots without dither noise
        scene.camera.data.show_passepartout = False  # no darkening outside the camera frame
        s = scene.ptir_render
        s.viewport_samples, s.viewport_pixel_size, s.bounces = SAMPLES, PIXEL, 1
        space = view3d.spaces.active
        space.show_region_ui = False
        space.show_region_toolbar = False
        space.overlay.show_overlays = OVERLAYS
        space.region_3d.view_perspective = "CAMERA"
        prefs = bpy.context.preferences.addons["ptir_blender"].preferences
        S["cli_pref"] = prefs.cli_path
        prefs.cli_path = os.path.join(WORK, "no_such_dir", "ptir")
        S["env_cli"] = os.environ.pop("PTIR_CLI", None)  # (find_cli would fall back to it)
        space.shading.type = "RENDERED"
        S["phase"], S["t_edit"] = "missing", time.monotonic()
        S["step"] = STEPS[0]
        return 0.1
    if S["phase"] == "missing":
        vr = viewport()
        if time.monotonic() - S["t_edit"] > TIMEOUT:
            fail("the viewport did not report the missing engine")
        if vr is None or "unavailable" not in vr.message:
            return 0.05
        S["result"]["missing_message"] = vr.message
        screenshot("missing")
        bpy.context.preferences.addons["ptir_blender"].preferences.cli_path = S["cli_pref"]
        if S["env_cli"]:
            os.environ["PTIR_CLI"] = S["env_cli"]
        vr.tag()
        S["phase"], S["t_edit"] = "wait", time.monotonic()
        return 0.05
    vr = viewport()
    step = S["step"]
    if time.monotonic() - S["t_edit"] > TIMEOUT:
        fail("step %s: the viewport did not finish in %.0f s (%s)" % (step, TIMEOUT, vr and vr._status(SAMPLES)))
    if S["phase"] == "wait":
        if step == "kill":
            # The kill step is done when the viewport has reported the death (its message).
            if vr is not None and "died" in vr.message:
                scene.ptir_render.viewport_samples = SAMPLES
                S["result"]["death_message"] = vr.message
                S["result"]["blender_alive_after_kill"] = True
                screenshot("killed")
                S["i"] += 1
                S["step"] = STEPS[S["i"]]
                S["t_edit"] = time.monotonic()
            return 0.05
        if vr is None or vr.samples < SAMPLES or vr.pending is not None or vr.first_pixels_s is None:
            return 0.05
        S["phase"] = "settle"  # one more redraw so the window shows the last pass
        vr.tag()
        return 0.3
    if S["phase"] == "settle":
        # From the edit (before Blender's depsgraph update, the sync and the deltas) to the first pass.
        rec = {"first_pixels_s": vr.first_pixels_at - S["t_edit"], "done_s": time.monotonic() - S["t_edit"],
               "sent_bytes": {k: v - S["sent_before"].get(k, 0) for k, v in sent().items()
                              if v - S["sent_before"].get(k, 0) > 0},
               "loads": engine_sync.session().loads, "screenshot": screenshot(step),
               "engine_pid": engine_sync.session().engine.proc.pid, "status": vr._status(SAMPLES)}
        if step == "film":  # the accumulated passes' alpha: 0 where only the world was seen, n where covered
            a = vr.accum[..., 3] / vr.samples
            rec["alpha_zero"], rec["alpha_one"] = float((a == 0.0).mean()), float((a == 1.0).mean())
        S["result"]["steps"][step] = rec
        print("VIEWPORT_STEP: %s %s" % (step, json.dumps(rec)), flush=True)
        S["i"] += 1
        if S["i"] >= len(STEPS):
            if KILL:
                scene.render.film_transparent = False  # (F12 is compared with the CLI's opaque film)
                S["result"]["f12"] = f12()
            print("VIEWPORT_CHECK: " + json.dumps(S["result"]), flush=True)
            print("ADDON_CHECK: OK", flush=True)
            engine_sync.shutdown()
            os._exit(0)
        S["step"] = STEPS[S["i"]]
        S["sent_before"] = sent()
        # Wait for the pass in flight of a step before changing the next, unless it is the kill.
        if S["step"] == "kill":
            scene.ptir_render.viewport_samples = 100000  # a pass is always running when the kill comes
            S["phase"] = "arm_kill"
            vr.tag()
            return 0.1
        S["t_edit"] = time.monotonic()
        edit(S["step"])
        S["phase"] = "wait"
        return 0.05
    if S["phase"] == "arm_kill":
        vr.tag()
        if vr is not None and vr.pending is not None and vr.samples >= 1:
            S["t_edit"] = time.monotonic()
            edit("kill")
            S["phase"] = "wait"
        return 0.05
    return 0.05


bpy.app.timers.register(tick, first_interval=1.0)
