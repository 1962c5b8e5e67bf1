"""The PTIR render engine (Render Properties > Render Engine > PTIR; F12 / bpy.ops.render.render()).

Design: the engine path-traces through the command-line tool in a child
process, not through the Python module in-process. A final render exports the
scene (blender/scene_bridge.py: meshes, lights, world, camera via
scene_export, plus the splat objects as world-space PLYs) to a temporary
folder, runs `ptir render scene.json -o render.exr --camera <scene camera>
--spp/--bounces/--interaction/...`, follows its progress bar on stderr
(update_progress; the status line shows the percentage and ETA), stops it when
the user presses Esc (test_break), and loads the EXR into the render result.
Why a child process: a native crash (out of memory, a bug in a new build) ends
that process and is reported as an error, instead of taking Blender and the
artist's unsaved work down; the scene export costs little next to the path
tracing; and the engine does not depend on the native module matching
Blender's Python (the CLI works with any Blender version). The image is the
CLI's, pixel for pixel (tests/blender/test_addon_render.py checks this).

Film: with Film > Transparent off the alpha is 1 (as Cycles); with it on, the
alpha is the coverage and pixels that no surface covers are (0, 0, 0, 0).
Viewport "Rendered" shading uses Eevee (bl_use_eevee_viewport).
"""

import os
import shutil
import tempfile
import time

import bpy
import numpy as np

from ..blender import scene_bridge, scene_export
from ..errors import PtirError
from ..io import cli, scene_file


def _preferences():
    addon = bpy.context.preferences.addons.get(__package__.rsplit(".", 1)[0])
    return addon.preferences if addon is not None else None


def cli_path():
    prefs = _preferences()
    return cli.find_cli(prefs.cli_path if prefs is not None else "")


def keep_files():
    prefs = _preferences()
    return bool(prefs is not None and prefs.keep_files) or bool(os.environ.get("PTIR_KEEP_FILES"))


def integrator_settings(settings):
    return {"spp": int(settings.spp), "bounces": int(settings.bounces), "seed": int(settings.seed),
            "interaction": settings.interaction, "tau_g": float(settings.tau_g)}


def render_args(cli_exe, scene_json, output, camera, settings):
    args = [cli_exe, "render", scene_json, "-o", output, "--camera", camera, "--spp", settings.spp,
            "--bounces", settings.bounces, "--seed", settings.seed, "--interaction", settings.interaction,
            "--tau-g", "%.9g" % settings.tau_g]
    if settings.threads > 0:
        args += ["--threads", settings.threads]
    return args


def read_exr_pixels(path, width, height):
    """(height * width, 4) float32 RGBA rows bottom-up (Blender's order) of a linear EXR, via Blender."""
    img = bpy.data.images.load(path, check_existing=False)
    try:
        if tuple(img.size) != (width, height):
            raise scene_export.ExportError("the engine wrote a %dx%d image, expected %dx%d"
                                           % (img.size[0], img.size[1], width, height))
        px = np.empty(width * height * 4, np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    return px.reshape(-1, 4)


class PTIRRenderEngine(bpy.types.RenderEngine):
    bl_idname = "PTIR"
    bl_label = "PTIR"
    bl_use_preview = False
    bl_use_eevee_viewport = True
    bl_use_postprocess = True

    def render(self, depsgraph):
        scene = depsgraph.scene
        r = scene.render
        width, height = scene_file.render_size(r.resolution_x, r.resolution_y, r.resolution_percentage)
        settings = scene.ptir_render
        job_dir = tempfile.mkdtemp(prefix="ptir_render_")
        keep = keep_files()
        try:
            self._render(depsgraph, scene, settings, width, height, job_dir)
        finally:
            if keep:
                print("ptir render: job files kept in %s" % job_dir)
            else:
                shutil.rmtree(job_dir, ignore_errors=True)

    def _fail(self, message):
        self.report({"ERROR"}, "PTIR: " + message)
        self.update_stats("", "PTIR: " + message)
        if bpy.app.background:
            print("ptir render: error: " + message, flush=True)

    def _render(self, depsgraph, scene, settings, width, height, job_dir):
        self.update_stats("", "PTIR: exporting the scene")
        warnings = []
        try:
            exe = cli_path()
            camera = scene_bridge.scene_camera_name(scene)
            scene_json, info = scene_bridge.export_engine_scene(
                out_dir=job_dir, depsgraph=depsgraph, integrator=integrator_settings(settings), warnings=warnings)
        except PtirError as e:
            self._fail(str(e))
            return
        if self.test_break():
            return
        output = os.path.join(job_dir, "render.exr")
        args = render_args(exe, scene_json, output, camera, settings)
        try:
            job = cli.ChildJob(args, parse=cli.parse_render_progress, echo=False,
                               log_path=os.path.join(job_dir, "render.log"))
        except PtirError as e:
            self._fail(str(e))
            return
        splats = sum(c for _, _, c in info["splats"])
        label = "PTIR: %d spp, %d bounces, %d splats" % (settings.spp, settings.bounces, splats)
        last_print, last_text = 0.0, None
        while job.poll() is None:
            if self.test_break():
                job.cancel(grace=2.0)
                self.update_stats("", "PTIR: cancelled")
                return
            text = "%s | %s" % (label, job.progress.text or "loading the scene")
            if text != last_text:  # (blender -b prints every stats update)
                last_text = text
                self.update_progress(job.progress.fraction)
                self.update_stats("", text)
            if bpy.app.background and time.monotonic() - last_print > 2.0 and job.progress.text:
                last_print = time.monotonic()
                print("ptir render: %s" % job.progress.text, flush=True)
            time.sleep(0.05)
        if job.proc.returncode != 0 or not os.path.exists(output):
            self._fail("render failed: %s" % job.error_message())
            return
        try:
            px = read_exr_pixels(output, width, height)
        except PtirError as e:
            self._fail(str(e))
            return
        if scene.render.film_transparent:
            px[px[:, 3] <= 0.0] = 0.0
        else:
            px[:, 3] = 1.0
        result = self.begin_result(0, 0, width, height)
        result.layers[0].passes["Combined"].rect = px
        self.end_result(result)
        self.update_progress(1.0)
        if bpy.app.background:
            print("ptir render: done (%dx%d)" % (width, height), flush=True)
        for w in warnings:
            self.report({"WARNING"}, "PTIR export: " + w)


# Built-in panels that also show for PTIR: the generic ones (COMPAT_ENGINES with
# BLENDER_RENDER: dimensions, output, colour management, ...) and the Eevee ones
# that edit what the engine reads (materials, world, lights).
_EXTRA_PANELS = ("EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface", "EEVEE_MATERIAL_PT_settings",
                 "EEVEE_WORLD_PT_surface", "DATA_PT_EEVEE_light", "DATA_PT_EEVEE_light_distance",
                 "RENDER_PT_film")
# DATA_PT_light duplicates DATA_PT_EEVEE_light; Freestyle lines are not rendered by the engine.
_EXCLUDED_PANELS = ("VIEWLAYER_PT_filter", "VIEWLAYER_PT_layer_passes", "DATA_PT_light")
_compat_added = []


def _wanted(name, cls, engines):
    if name in _EXCLUDED_PANELS or "freestyle" in name.lower():
        return False
    if "BLENDER_RENDER" in engines or name in _EXTRA_PANELS:
        return True
    # Newer Blenders rename the Eevee panels: take the Eevee panels that edit materials, the world
    # and lights (what the engine reads).
    eevee = bool(engines & {"BLENDER_EEVEE", "BLENDER_EEVEE_NEXT"})
    return eevee and getattr(cls, "bl_context", "") in ("material", "world", "data") \
        and ("surface" in name.lower() or "light" in name.lower() or "context_material" in name.lower())


def register_compat_panels():
    for name in dir(bpy.types):
        cls = getattr(bpy.types, name, None)
        engines = getattr(cls, "COMPAT_ENGINES", None)
        if not isinstance(engines, set):
            continue
        if _wanted(name, cls, engines) and "PTIR" not in engines:
            engines.add("PTIR")
            _compat_added.append(cls)


def unregister_compat_panels():
    while _compat_added:
        cls = _compat_added.pop()
        cls.COMPAT_ENGINES.discard("PTIR")


classes = (PTIRRenderEngine,)
