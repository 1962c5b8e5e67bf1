"""The PTIR render engine (Render Properties > Render Engine > PTIR; F12 and Viewport Shading > Rendered).

Design: the engine runs in a child process, never in Blender's: the persistent
`ptir serve` process of the session (blender/engine_sync.py; protocol in
docs/engine_protocol.md) holds the loaded scene. Why a child process: a native
crash (out of memory, a bug in a new build) ends that process and is reported,
instead of taking Blender and the artist's unsaved work down; and the engine
does not depend on the native module matching Blender's Python.

F12 (render): the session's engine is brought up to date with deltas
(engine_sync.sync: nothing is re-exported when nothing changed; lights, world
and material edits are sent as such; geometry changes re-export and reload),
then renders the scene camera, exported exactly as the scene file would hold it,
at the PTIR settings: the image is the CLI's (`ptir render scene.json`) pixel for
pixel (tests/blender/test_addon_render.py). Esc cancels the request. With
Render Passes on, the AOVs (depth, normal, albedo, roughness, metallic, opacity)
are added as render passes for the compositor. In blender -b the engine process
is ended after the render (no viewport will reuse it).

Viewport (view_update / view_draw): blender/viewport_render.py draws progressive
passes from the same process; view_update sends the depsgraph's changes as
deltas. When the engine is missing or died, the viewport says so and starts a
new one on the next redraw.

Film: with Film > Transparent off the alpha is 1 (as Cycles); with it on, the
engine leaves the directly seen world out (the render request's "transparent"):
RGB is premultiplied by the coverage A, the associated alpha Blender's render
result holds and Cycles writes (docs/alpha.md), and pixels that no surface covers
are (0, 0, 0, 0).
"""

import os
import shutil
import tempfile
import time

import bpy

from ..blender import engine_sync, scene_bridge, scene_export, viewport_render
from ..blender.preferences import cli_path, keep_files
from ..blender.render_pixels import read_exr_pixels
from ..errors import PtirError
from ..io import engine_process, scene_file
# (render_args: the CLI's command line of this render, for the tests that compare the two)
from ..io.engine_client import (integrator_settings, render_args,  # noqa: F401
                                render_camera_request, render_progress_text)
from ..io.raw_pixels import AOV_PASSES, read_raw_pass


class PTIRRenderEngine(bpy.types.RenderEngine):
    bl_idname = "PTIR"
    bl_label = "PTIR"
    bl_use_preview = False
    bl_use_postprocess = True

    def __init__(self, *args, **kwargs):
        # (Blender 4.x and later pass the engine's data to __init__; 3.x passes nothing)
        super().__init__(*args, **kwargs)
        self._viewport = None

    # ------------------------------------------------------------------ F12

    def render(self, depsgraph):
        scene = depsgraph.scene
        r = scene.render
        width, height = scene_file.render_size(r.resolution_x, r.resolution_y, r.resolution_percentage)
        settings = scene.ptir_render
        job = {}  # the job's folder, made in the engine's session folder (the only place it writes)
        keep = keep_files()
        try:
            self._render(depsgraph, scene, settings, width, height, job)
        finally:
            job_dir = job.get("dir")
            if job_dir and keep:
                print("ptir render: job files kept in %s" % job_dir)
            elif job_dir:
                shutil.rmtree(job_dir, ignore_errors=True)
            if bpy.app.background:
                engine_sync.shutdown()

    def update_render_passes(self, scene=None, renderlayer=None):
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        if scene is not None and scene.ptir_render.aov_passes:
            for name, _, n, chans, kind, _ in AOV_PASSES:
                self.register_pass(scene, renderlayer, name, n, chans, kind)

    def _fail(self, message):
        self.report({"ERROR"}, "PTIR: " + message)
        self.update_stats("", "PTIR: " + message)
        if bpy.app.background:
            print("ptir render: error: " + message, flush=True)

    def _render(self, depsgraph, scene, settings, width, height, job):
        self.update_stats("", "PTIR: updating the engine's scene")
        session = engine_sync.session()
        try:
            with session.lock:
                session.ensure(cli_path(), threads=settings.threads)
                job_dir = job["dir"] = tempfile.mkdtemp(prefix="render_", dir=session.folder)
                output = os.path.join(job_dir, "render.exr")
                aovs = ({a: os.path.join(job_dir, a + ".raw") for _, a, *_ in AOV_PASSES} if settings.aov_passes
                        else {})
                sync = session.sync(depsgraph, integrator_settings(settings), exact=True)
                warnings = []
                camera = scene_export.camera_entry(scene.camera, scene, warnings) if scene.camera else None
                if camera is None:
                    scene_bridge.scene_camera_name(scene)  # raises the message
                rid = session.engine.send(render_camera_request(camera, output, aovs, scene.render.film_transparent))
            label = "PTIR: %d spp, %d bounces%s" % (settings.spp, settings.bounces,
                                                   "" if sync["load"] else " (scene unchanged: no re-export)")
            self.update_stats("", label)
            if bpy.app.background:
                print("ptir render: %s" % label, flush=True)
            started = time.monotonic()
            shown = {"text": None}

            def progress(f):
                text = render_progress_text(label, f, time.monotonic() - started)
                if text != shown["text"]:  # (blender -b prints every stats update)
                    shown["text"] = text
                    self.update_progress(f)
                    self.update_stats("", text)

            reply = session.engine.wait(rid, should_cancel=self.test_break, on_progress=progress)
        except PtirError as e:
            self._fail(str(e))
            return
        if reply.get("cancelled"):
            self.update_stats("", "PTIR: cancelled")
            if bpy.app.background:
                engine_sync.shutdown()
            return
        if not reply.get("ok"):
            self._fail("render failed: %s" % reply.get("error"))
            return
        try:
            px = read_exr_pixels(output, width, height)
        except PtirError as e:
            self._fail(str(e))
            return
        if not scene.render.film_transparent:
            px[:, 3] = 1.0  # an opaque film (the world is seen behind the objects)
        result = self.begin_result(0, 0, width, height)
        layer = result.layers[0]
        layer.passes["Combined"].rect = px
        for name, aov, _, _, _, used in AOV_PASSES:
            if aov in aovs and layer.passes.find(name) >= 0:
                layer.passes[name].rect = read_raw_pass(aovs[aov], width, height, used)
        self.end_result(result)
        self.update_progress(1.0)
        if bpy.app.background:
            print("ptir render: done (%dx%d)" % (width, height), flush=True)
        for w in session.warnings:
            self.report({"WARNING"}, "PTIR export: " + w)

    # ------------------------------------------------------------------ viewport

    def _view(self):
        if self._viewport is None:
            self._viewport = viewport_render.ViewportRender(self)
        return self._viewport

    def view_update(self, context, depsgraph):
        session = engine_sync.session()
        if not session.alive():
            return  # view_draw starts it (and says why when it cannot)
        changed, data, world = set(), set(), False
        for u in depsgraph.updates:
            idv = u.id
            if isinstance(idv, bpy.types.Object):
                name = idv.original.name if idv.original else idv.name
                changed.add(name)
                if u.is_updated_geometry or u.is_updated_shading:
                    data.add(name)
            elif isinstance(idv, (bpy.types.World,)):
                world = True
        try:
            with session.lock:
                res = session.sync(depsgraph, integrator_settings(depsgraph.scene.ptir_render),
                                   changed=changed, world_changed=world, data_changed=data)
        except PtirError as e:
            self._view().message = str(e)
            return
        if res["sent"]:
            self._view().scene_changed()

    def view_draw(self, context, depsgraph):
        vr = self._view()
        session = engine_sync.session()
        settings = depsgraph.scene.ptir_render
        if not session.alive():
            if session.engine is not None:
                # It died: say so on this redraw; the next one starts a new process.
                vr.message = session.engine.death_message() + " (restarting on the next redraw)"
                session.stop()
                vr.restart()
                self.update_stats("", "PTIR: " + vr.message)
                viewport_render.schedule_redraw(vr, 0.5)
                return
            try:
                with session.lock:
                    session.ensure(cli_path(), threads=settings.threads)
                    session.sync(depsgraph, integrator_settings(settings))
                vr.message = ""
                vr.scene_changed()
            except PtirError as e:
                # Said in the header; the next redraw (any change, or moving the view) tries again.
                vr.message = viewport_render.engine_missing_message(e)
                self.update_stats("", "PTIR: " + vr.message)
                return
        try:
            text = vr.draw(context, depsgraph, session, settings.viewport_samples, settings.viewport_pixel_size)
        except engine_process.EngineDied:
            viewport_render.schedule_redraw(vr, 0.05)
            return
        self.update_stats("", text)


classes = (PTIRRenderEngine,)
