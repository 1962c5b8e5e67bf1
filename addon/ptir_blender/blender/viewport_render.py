"""The live PTIR viewport (Viewport Shading > Rendered): progressive passes from the persistent engine.

A ViewportRender belongs to one RenderEngine instance (one 3D view). Each view
state (view matrix, projection, region size, scene generation) starts a
sequence of passes sent to the engine one at a time:

  pass 0:   1 spp at 1/(4 * pixel size) resolution (first pixels fast)
  pass k>0: 1 spp at 1/(pixel size) resolution, sample index k - 1, accumulated
            (the running mean of passes 1..k is the k-spp render of that view)

until Viewport Samples is reached. A change (camera move, edit) cancels the pass
in flight and starts over. A timer (bpy.app.timers, main thread) asks the engine
for the reply, which reads its pipe without blocking (io/pipe_lines.py: no reader
threads), and tags the view for redraw when one has arrived. Pixels come back as raw float32 RGBA
files in /dev/shm and go to the GPU as one texture (no per-pixel Python).

Film > Transparent: the passes leave the directly seen world out and keep the coverage as alpha
(associated RGBA, docs/alpha.md), drawn premultiplied over the viewport's background as Cycles draws
its own; otherwise the picture is opaque (alpha 1).
"""

import math
import os
import time
import weakref

import bpy
import gpu
import numpy as np
from gpu_extras.presets import draw_texture_2d

from ..errors import PtirError
from ..io import engine_client, engine_process

FIRST_PASS_DIVIDER = 4

_active = weakref.WeakSet()


def _poll_timer():
    """Main-thread timer: redraws views whose engine answered; stops when none waits."""
    waiting = False
    for vr in list(_active):
        try:
            if vr.reply_ready():
                vr.tag()
            waiting = waiting or vr.busy()
        except ReferenceError:
            continue
    return 0.03 if waiting else None


def _ensure_timer():
    if not bpy.app.timers.is_registered(_poll_timer):
        bpy.app.timers.register(_poll_timer, first_interval=0.03)


def view_camera(region, rv3d, divider):
    """The engine's "view" camera of a 3D view at 1/divider resolution (None for orthographic views)."""
    if not rv3d.is_perspective:
        return None
    w = max(1, int(math.ceil(region.width / divider)))
    h = max(1, int(math.ceil(region.height / divider)))
    p = rv3d.window_matrix
    c2w = rv3d.view_matrix.inverted()
    # NDC x = P00 * x/(-z) - P02 (likewise y); pixel u = (x_ndc + 1) w / 2, v = (1 - y_ndc) h / 2.
    return {"c2w": [float(c2w[r][c]) for r in range(4) for c in range(4)],
            "fx": 0.5 * w * p[0][0], "fy": 0.5 * h * p[1][1],
            "cx": 0.5 * w * (1.0 - p[0][2]), "cy": 0.5 * h * (1.0 + p[1][2]), "width": w, "height": h}


class ViewportRender:
    def __init__(self, engine):
        self._engine_ref = weakref.ref(engine)
        self.key = None
        self.generation = 0     # bumped by every scene change sent
        self.passes = 0         # passes received for the current key
        self.samples = 0        # accumulated samples (full resolution passes)
        self.pending = None     # (request id, pass index, key, output file)
        self.accum = None       # float32 (h, w, 4) sum of the full-resolution passes
        self.texture = None
        self.texture_size = None
        self.started = time.monotonic()
        self.first_pixels_s = None  # seconds from the restart to the first pass shown
        self.first_pixels_at = None  # time.monotonic() of that moment
        self.message = ""
        self.session = None
        self.view_cams = None   # (full, first-pass) engine cameras of the last draw (kick() reuses them)
        self.transparent = False  # the scene's Film > Transparent at the last draw
        _active.add(self)

    # ---------------------------------------------------------------- state

    def tag(self):
        engine = self._engine_ref()
        if engine is not None:
            engine.tag_redraw()

    def busy(self):
        return self.pending is not None

    def reply_ready(self):
        if self.pending is None or self.session is None or self.session.engine is None:
            return False
        if not self.session.engine.alive():
            return True
        return self.session.engine.reply(self.pending[0], pop=False) is not None

    def restart(self):
        """Forget the accumulated passes; cancels the pass in flight."""
        if self.pending is not None and self.session is not None and self.session.alive():
            self.session.engine.cancel(self.pending[0])
        self.pending = None
        self.passes = 0
        self.samples = 0
        self.accum = None
        self.started = time.monotonic()
        self.first_pixels_s = None

    def scene_changed(self):
        self.generation += 1
        self.key = None

    # ---------------------------------------------------------------- draw

    def draw(self, context, depsgraph, session, target_samples, pixel_size):
        """One view_draw: takes an arrived pass, sends the next, draws the texture. Returns the status text."""
        self.session = session
        region, rv3d = context.region, context.region_data
        full = view_camera(region, rv3d, pixel_size)
        if full is None:
            self.view_cams = None
            return "PTIR: orthographic views are not supported in the viewport (use a perspective view)"
        self.view_cams = (full, view_camera(region, rv3d, pixel_size * FIRST_PASS_DIVIDER))
        self.transparent = bool(depsgraph.scene.render.film_transparent)
        key = self._key(full)
        if key != self.key:
            self.restart()
            self.key = key
        self._collect()
        if self.pending is None and self.samples < target_samples:
            self._send_pass(self.view_cams[1] if self.passes == 0 else full)
        self._draw_texture(region)
        return self._status(target_samples)

    def _key(self, full):
        return (tuple(full["c2w"]), full["fx"], full["fy"], full["cx"], full["cy"], full["width"], full["height"],
                self.generation, self.transparent)

    def _send_pass(self, cam):
        out = self.session.file("view.raw")
        rid = self.session.engine.send(engine_client.render_view_request(
            cam, 1, 0 if self.passes == 0 else self.samples, out, self.transparent))
        self.pending = (rid, self.passes, self.key, out, cam["width"], cam["height"])
        _ensure_timer()

    def kick(self):
        """The scene changed and its delta is already sent (a material edit, straight from the operator):
        the first pass of the new state is requested now, so the engine renders it while Blender does its
        own update, undo step and redraw; the next draw finds it pending under the same key."""
        if self.view_cams is None or self.session is None or not self.session.alive():
            self.scene_changed()
            return
        self.scene_changed()
        self.restart()
        self.key = self._key(self.view_cams[0])
        self._send_pass(self.view_cams[1])

    def _collect(self):
        if self.pending is None:
            return
        rid, index, key, out, w, h = self.pending
        reply = self.session.engine.reply(rid)  # raises EngineDied when the process ended
        if reply is None:
            return
        self.pending = None
        try:
            if key != self.key or not reply.get("ok"):
                if not reply.get("ok") and not reply.get("cancelled"):
                    self.message = reply.get("error", "render failed")
                return
            px = np.fromfile(out, np.float32).reshape(h, w, 4)
        finally:
            if os.path.exists(out):
                os.remove(out)
        self.message = ""
        if index == 0:
            self._upload(px, 1)
        else:
            self.accum = px.copy() if self.accum is None else self.accum + px
            self.samples += 1
            self._upload(self.accum, self.samples)
        if self.first_pixels_s is None:
            self.first_pixels_at = time.monotonic()
            self.first_pixels_s = self.first_pixels_at - self.started
        self.passes += 1

    def _upload(self, px, n):
        h, w = px.shape[:2]
        rgba = px[::-1] * (1.0 / n)  # top row first -> OpenGL's bottom row first
        if not self.transparent:
            rgba[..., 3] = 1.0
        buf = gpu.types.Buffer("FLOAT", rgba.size, np.ascontiguousarray(rgba, np.float32).reshape(-1))
        self.texture = gpu.types.GPUTexture((w, h), format="RGBA16F", data=buf)
        self.texture_size = (w, h)

    def _draw_texture(self, region):
        if self.texture is None:
            return
        engine = self._engine_ref()
        gpu.state.blend_set("ALPHA_PREMULT")
        engine.bind_display_space_shader(bpy.context.scene)
        draw_texture_2d(self.texture, (0, 0), region.width, region.height)
        engine.unbind_display_space_shader()
        gpu.state.blend_set("NONE")

    def _status(self, target):
        if self.message:
            return "PTIR: " + self.message
        t = time.monotonic() - self.started
        if self.samples >= target:
            return "PTIR: %d/%d samples, %.1f s (done)" % (self.samples, target, t)
        if self.samples == 0:
            return "PTIR: preview, %.1f s" % t
        return "PTIR: %d/%d samples, %.1f s" % (self.samples, target, t)


def kick_all():
    """kick() on every live viewport."""
    for vr in list(_active):
        vr.kick()
        vr.tag()


def schedule_redraw(vr, seconds):
    """Redraws vr's view after `seconds` (main-thread timer)."""
    ref = weakref.ref(vr)

    def fire():
        v = ref()
        if v is not None:
            v.tag()
        return None

    bpy.app.timers.register(fire, first_interval=seconds)


def engine_missing_message(error):
    return "PTIR engine unavailable: %s" % error
