"""Optimise: recover the splats' (and chosen mesh) materials and the environment from photos.

    bpy.ops.ptir.optimize()          settings in scene.ptir_optimize (the PTIR sidebar panel)

Runs `ptir optimize` as a child process (a native crash cannot take Blender
down), after `ptir fit` when the geometry stage is on (Fit Geometry;
blender/optimize_job.py says when): the stages run one after the other, the
progress bar covers both, Esc or Cancel stops whichever runs, and a failed or
cancelled stage ends the whole run with nothing changed. In the UI (INVOKE) it
is modal: a timer polls the job, the panel, the status bar and the window's
progress indicator show iteration, loss and ETA; Esc (or the panel's Cancel
button) stops it. From a script / blender -b
(EXEC) it blocks until the end and prints the optimiser's progress lines.
Only a run that finishes writes anything back (blender/optimize_job.py); a
failed or cancelled run leaves the scene as it was.
"""

import os
import shutil
import tempfile
import time

import bpy

from ..blender import optimize_estimate, optimize_job, preferences
from ..errors import PtirError
from ..io import cli, engine_client

_state = {"job": None, "cancel": False}


def request_cancel():
    """Asks the running optimisation (modal or blocking) to stop."""
    _state["cancel"] = True


def stop_all_jobs():
    job = _state.get("job")
    if job is not None and job.poll() is None:
        job.cancel(grace=2.0)
    _state["job"] = None


def _redraw(context):
    wm = context.window_manager
    for window in wm.windows:
        for area in window.screen.areas:
            if area.type in ("VIEW_3D", "PROPERTIES"):
                area.tag_redraw()


class _OptimizeRun:
    """The run of an optimisation as an operator (a mixin: Blender registers each operator class on its
    own, and a registered operator class cannot be subclassed)."""

    _timer = None
    _child = None
    _prepared = None
    _job_dir = None
    _stages = ()
    _t_start = 0.0
    _stage = 0
    _echo = False

    @classmethod
    def poll(cls, context):
        return _state.get("job") is None

    # -------------------------------------------------------------- shared

    def _start(self, context, echo):
        settings = context.scene.ptir_optimize
        self._job_dir = tempfile.mkdtemp(prefix="ptir_optimize_")
        out_dir = bpy.path.abspath(settings.output_dir) if settings.output_dir else None
        self._pack = out_dir is None and not preferences.keep_files()
        exe = preferences.cli_path()
        self._prepared = self._prepare_job(context, settings, exe, out_dir)
        for w in self._prepared.warnings:
            self.report({"WARNING"}, w)
        self._echo = echo
        self._stages = ([("fit", self._prepared.fit_args)] if self._prepared.fit_args else []) + \
            [("optimize", self._prepared.args)]
        self._stage = 0
        self._t_start = time.monotonic()
        _state["cancel"] = False
        settings.running = True
        settings.progress = 0.0
        settings.capture_subject = ""
        settings.status = "starting"
        self._launch()

    def _prepare_job(self, context, settings, exe, out_dir):
        return optimize_job.prepare(context, settings, self._job_dir, exe, out_dir)

    def _launch(self):
        """Starts stage self._stage as the child job."""
        name, args = self._stages[self._stage]
        if name == "optimize":  # under a time preset: what the fit left of it
            args = optimize_job.inversion_args(self._prepared, time.monotonic() - self._t_start)
        if self._echo:
            print("ptir %s: %s" % (name, " ".join(args)), flush=True)
        self._child = cli.ChildJob(args, parse=cli.parse_optimize_progress, echo=self._echo,
                                   log_path=os.path.join(self._job_dir, "%s.log" % name))
        _state["job"] = self._child

    def _next_stage(self, rc):
        """After a stage ended with rc: starts the next one and returns True, else False (the run ends)."""
        if rc != 0 or self._child.cancelled or _state["cancel"] or self._stage + 1 >= len(self._stages):
            return False
        self._stage += 1
        self._launch()
        return True

    def _show_progress(self, settings, p):
        """The run's progress over all stages; the status names the stage when there are several."""
        n = len(self._stages)
        settings.progress = (self._stage + p.fraction) / n
        if getattr(p, "subject", ""):
            settings.capture_subject = p.subject
        text = p.text or "starting"
        settings.status = text if n == 1 else "%s %d/%d: %s" % (
            "fit" if self._stages[self._stage][0] == "fit" else "optimise", self._stage + 1, n, text)

    def _finish(self, context, rc):
        """Applies the results after a successful run; returns the operator result."""
        settings = context.scene.ptir_optimize
        child, prepared = self._child, self._prepared
        try:
            if child.cancelled or rc == 130:
                self.report({"WARNING"}, "Optimisation cancelled; nothing was changed")
                settings.status = "cancelled"
                return {"CANCELLED"}
            if rc != 0:
                msg = child.error_message()
                if self._stages[self._stage][0] == "fit":
                    msg = "geometry fit: " + msg
                self.report({"ERROR"}, "Optimisation failed: %s" % msg)
                settings.status = "failed: %s" % msg
                return {"CANCELLED"}
            try:
                results = optimize_job.load_results(prepared, pack_environment=self._pack)
                summary = optimize_job.apply_results(context, results)
            except PtirError as e:
                self.report({"ERROR"}, "Optimisation results not applied: %s" % e)
                settings.status = "failed: %s" % e
                return {"CANCELLED"}
            settings.status = "done: %s" % summary
            settings.progress = 1.0
            self.report({"INFO"}, "Optimised: %s" % summary)
            return {"FINISHED"}
        finally:
            settings.running = False
            _state["job"] = None
            _state["cancel"] = False
            if preferences.keep_files():
                print("ptir optimize: job files kept in %s" % self._job_dir)
            else:
                shutil.rmtree(self._job_dir, ignore_errors=True)

    def _abort_start(self, context, e):
        context.scene.ptir_optimize.running = False
        _state["job"] = None
        if self._job_dir:
            shutil.rmtree(self._job_dir, ignore_errors=True)
        self.report({"ERROR"}, str(e))
        return {"CANCELLED"}

    # -------------------------------------------------------------- blocking (scripts, blender -b)

    def execute(self, context):
        try:
            self._start(context, echo=True)
        except PtirError as e:
            return self._abort_start(context, e)
        settings = context.scene.ptir_optimize

        def on_progress(p):
            self._show_progress(settings, p)

        while True:
            try:
                rc = self._child.run_blocking(on_progress=on_progress, interval=0.25,
                                              should_cancel=lambda: _state["cancel"])
            except KeyboardInterrupt:
                rc = self._child.cancel()
            if not self._next_stage(rc):
                return self._finish(context, rc)

    # -------------------------------------------------------------- modal (UI)

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        try:
            self._start(context, echo=False)
        except PtirError as e:
            return self._abort_start(context, e)
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.25, window=context.window)
        wm.progress_begin(0.0, 1.0)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _end_modal(self, context):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)

    def modal(self, context, event):
        settings = context.scene.ptir_optimize
        if event.type == "ESC" or _state["cancel"]:
            settings.status = "cancelling"
            rc = self._child.cancel()
            self._end_modal(context)
            _redraw(context)
            return self._finish(context, rc)
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        rc = self._child.poll()
        if rc is not None and self._next_stage(rc):
            rc = None
        self._show_progress(settings, self._child.progress)
        context.window_manager.progress_update(settings.progress)
        if context.workspace is not None:
            context.workspace.status_text_set("PTIR optimise: %s  (Esc: cancel)" % settings.status)
        _redraw(context)
        if rc is None:
            return {"PASS_THROUGH"}
        self._end_modal(context)
        result = self._finish(context, rc)
        _redraw(context)
        return result

    def cancel(self, context):  # Blender ends the operator (file load, quit)
        if self._child is not None and self._child.poll() is None:
            self._child.cancel(grace=2.0)
        self._end_modal(context)
        _state["job"] = None
        context.scene.ptir_optimize.running = False


class PTIR_OT_optimize(_OptimizeRun, bpy.types.Operator):
    """Recover materials and lighting from the photos with the PTIR optimiser (runs in a child process; Esc cancels)"""
    bl_idname = "ptir.optimize"
    bl_label = "Optimise Materials"
    bl_options = {"REGISTER", "UNDO"}


class PTIR_OT_optimize_cancel(bpy.types.Operator):
    """Stop the running optimisation (nothing is written back)"""
    bl_idname = "ptir.optimize_cancel"
    bl_label = "Cancel Optimisation"

    @classmethod
    def poll(cls, context):
        return _state.get("job") is not None

    def execute(self, context):
        request_cancel()
        return {"FINISHED"}


class PTIR_OT_optimize_estimate(bpy.types.Operator):
    """Measure how long Optimise will take with these settings (exports the inputs, loads them in the engine and
    times a probe of the first view; blender/optimize_estimate.py)"""
    bl_idname = "ptir.optimize_estimate"
    bl_label = "Estimate Duration"

    @classmethod
    def poll(cls, context):
        return _state.get("job") is None

    def execute(self, context):
        settings = context.scene.ptir_optimize
        try:
            optimize_estimate.measure(context, settings, preferences.cli_path())
        except PtirError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        total = optimize_estimate.seconds(context, settings)
        self.report({"INFO"}, "Optimise: about %s (%.2f s/iteration)" % (optimize_estimate.duration_text(total),
                                                                          settings.estimate_s_per_iter))
        _redraw(context)
        return {"FINISHED"}


class PTIR_OT_make_relightable(_OptimizeRun, bpy.types.Operator):
    """Make the splat object relightable: recover its materials and the light from the photos of the
    panel's dataset folder when one is set, else from the splats' own captured radiance (no photos
    needed; runs in a child process; Esc cancels)"""
    bl_idname = "ptir.make_relightable"
    bl_label = "Make Relightable"
    bl_options = {"REGISTER", "UNDO"}

    # Without photos: 0 keeps `ptir optimize`'s own default for that path (docs/relightable.md).
    iterations: bpy.props.IntProperty(name="Iterations", default=0, min=0,
                                      description="Iterations without photos (0: the engine's default, 400)")
    samples: bpy.props.IntProperty(name="Samples", default=0, min=0,
                                   description="Samples per pixel per iteration without photos (0: 16)")
    views: bpy.props.IntProperty(name="Views", default=0, min=0,
                                 description="Virtual views around the splats (0: from the splat count)")
    size: bpy.props.IntProperty(name="View Size", default=0, min=0,
                                description="Side of the virtual views in pixels (0: from the splat count)")

    def _prepare_job(self, context, settings, exe, out_dir):
        # Decision: the photos when the panel names a dataset folder that exists (the better answer:
        # docs/relightable.md), else the splats' own radiance at the command's defaults for it.
        photos = settings.source == "DATASET" and optimize_estimate.dataset_problem(settings) is None
        job = optimize_job.prepare(context, settings, self._job_dir, exe, out_dir,
                                   source=None if photos else "SPLATS", own_defaults=not photos)
        if not photos:
            job.args += engine_client.relightable_overrides(self.iterations, self.samples, self.views, self.size)
            print("ptir make relightable: no dataset folder: materials from the splats' own radiance", flush=True)
        return job


classes = (PTIR_OT_optimize, PTIR_OT_optimize_cancel, PTIR_OT_optimize_estimate, PTIR_OT_make_relightable)
