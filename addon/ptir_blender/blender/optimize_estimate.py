"""How long an optimisation will take, shown in the Optimise panel before it starts.

Decision: measured, not modelled. A rate model (Gaussians x pixels x spp x bounces) calibrated
once would be wrong on another machine, under another load, or for a scene whose cost is in
the meshes or the background. Instead `measure` does what pressing Optimise does up to the first
iteration -- optimize_job.prepare writes the same inputs, and `ptir optimize ... --estimate`
loads them, builds the BVH and times a probe of the first training view
(native/src/ptir/optim/iteration_estimate.h, the estimate the CLI prints before every run) --
and stores the result in the scene's settings:

    estimate_setup_s     seconds before the first iteration (Blender's export + the engine's
                         loading, BVH build and probe, as the real run spends them)
    estimate_s_per_iter  seconds per iteration
    estimate_fit_s_per_iter  seconds per iteration of the geometry stage, when the flow fits first
                         (the median of a few real `ptir fit` iterations on the input, times
                         FIT_GROWTH: the densification grows the count to at most 1.5x; over whole
                         fits the mean iteration took 1.24x the first ones on the textured 128^2
                         set and 0.93x on a 32^2 one, where fixed costs dominate)
    estimate_key         the settings it was measured for (key() below)

The panel shows setup + iterations x s/iter while the key matches (the iteration count is not
part of the key: changing it rescales the estimate without a new probe). On the demo's sample
(9,408 Gaussians, 16 views of 100 x 100, 16 spp, 2 bounces) the probe says 0.33 s/iter and a
20-iteration run measures 0.30 s/iter on the 2-core reference machine.
"""

import json
import os
import shutil
import tempfile
import time

import bpy
import numpy as np

from ..errors import OptimizeError
from ..io import engine_client
from . import optimize_job, splat_object

FIT_GROWTH = 1.1
FIT_PROBE_ITERS = 8


def _visible_meshes(context):
    return [o for o in context.visible_objects if o.type == "MESH" and not splat_object.is_splat_object(o)]


def key(context, settings):
    """The settings an estimate depends on (everything but the iteration count), as a string."""
    obj = settings.splat_object
    if obj is None:
        active = context.view_layer.objects.active if context.view_layer else None
        obj = active if splat_object.is_splat_object(active) else None
    parts = [settings.source, bpy.path.abspath(settings.dataset_dir) if settings.source == "DATASET" else "",
             settings.split, obj.name if obj else "", len(obj.data.vertices) if obj else 0, settings.spp,
             settings.bounces, settings.views_per_iter, settings.crop, settings.env, settings.env_width,
             settings.env_height, settings.optimize_meshes, settings.optimize_metallic, settings.learn_exposure,
             settings.threads, len(_visible_meshes(context)), settings.fit_geometry, settings.preset]
    return json.dumps(parts)


def measure(context, settings, cli_exe):
    """Measures the estimate for the current settings and stores it in them; returns the seconds per
    iteration. Raises OptimizeError (and the io errors) as Optimise would. Without photos (source SPLATS)
    the engine renders the first radiance target and counts its time for every other view in setup_s."""
    job_dir = tempfile.mkdtemp(prefix="ptir_estimate_")
    try:
        t0 = time.monotonic()
        job = optimize_job.prepare(context, settings, job_dir, cli_exe)
        probe = engine_client.run_to_end(engine_client.estimate_args(job.args, job.fit_args))
        wall = time.monotonic() - t0
        line = next((l for l in probe.lines if l.startswith('{"estimate"')), None)
        if probe.proc.returncode != 0 or line is None:
            raise OptimizeError("estimate failed: %s" % probe.error_message())
        est = json.loads(line)["estimate"]
        fit_setup, fit_s = _measure_fit(job, job_dir) if job.fit_args else (0.0, 0.0)
    finally:
        shutil.rmtree(job_dir, ignore_errors=True)
    settings.estimate_setup_s = wall + fit_setup  # export + process starts + loads + BVHs + probe: what a run spends first
    settings.estimate_s_per_iter = float(est["s_per_iter"])
    settings.estimate_fit_s_per_iter = fit_s
    settings.estimate_key = key(context, settings)
    return settings.estimate_s_per_iter


def _measure_fit(job, job_dir):
    """(setup seconds, seconds per fit iteration) of the job's geometry stage, from a few real
    iterations of its own command line into a scratch folder."""
    out = os.path.join(job_dir, "fit_probe")
    t0 = time.monotonic()
    probe = engine_client.run_to_end(engine_client.fit_probe_args(job.fit_args, out, FIT_PROBE_ITERS))
    wall = time.monotonic() - t0
    log = os.path.join(out, "log.csv")
    if probe.proc.returncode != 0 or not os.path.isfile(log):
        raise OptimizeError("estimate of the geometry fit failed: %s" % probe.error_message())
    with open(log) as f:
        rows = [l.split(",") for l in f.read().splitlines()]
    col = rows[0].index("seconds")
    per = [float(r[col]) for r in rows[1:]]
    steady = float(np.median(per[1:] if len(per) > 1 else per))
    return max(0.0, wall - sum(per)), steady * FIT_GROWTH


def seconds(context, settings):
    """The estimated duration of Optimise with the current settings, or None when not measured for them
    (a time preset: its seconds, which the run plans itself to end within)."""
    budget = optimize_job.preset_seconds(settings)
    if budget:
        return budget
    if not settings.estimate_key or settings.estimate_key != key(context, settings):
        return None
    fit = settings.fit_iterations * settings.estimate_fit_s_per_iter
    return settings.estimate_setup_s + fit + settings.iterations * settings.estimate_s_per_iter


def duration_text(s):
    s = max(0.0, float(s))
    if s < 90:
        return "%.0f s" % s
    if s < 5400:
        return "%.0f min" % (s / 60.0) if s >= 600 else "%d min %02d s" % (s // 60, s % 60)
    return "%.1f h" % (s / 3600.0)


def dataset_problem(settings):
    """Why the Dataset folder cannot be used (a panel message), or None."""
    if settings.source != "DATASET":
        return None
    if not settings.dataset_dir:
        return "Choose the dataset folder"
    path = bpy.path.abspath(settings.dataset_dir)
    if not os.path.isdir(path):
        return "Dataset folder not found: %s" % path
    return None
