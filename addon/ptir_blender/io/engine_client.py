"""The add-on's one client of the engine, without bpy: what it asks the engine for, in one place.

Two ways in, both child processes (a native crash never takes Blender down):
    `ptir serve`   the session's persistent engine (engine_process.EngineProcess; the protocol in
                   docs/engine_protocol.md): the requests below build its JSON lines
    `ptir <cmd>`   one-off jobs (optimize, fit, cameras, the estimate): the argument builders below
                   make their command lines, cli.ChildJob runs them and reads their progress

Everything here takes plain values or duck-typed settings objects (an add-on property group is
read by attribute only), so it is testable with plain pytest; the operators and blender/ modules
call it instead of spelling requests and command lines themselves.
"""

from . import cli

# ---------------------------------------------------------------------------------------------
# `ptir serve` requests (docs/engine_protocol.md)


def integrator_settings(settings):
    """The scene file's "integrator" entry from the PTIR render settings (spp, bounces, seed, ...)."""
    return {"spp": int(settings.spp), "bounces": int(settings.bounces), "seed": int(settings.seed),
            "interaction": settings.interaction, "tau_g": float(settings.tau_g)}


def load_request(scene_json):
    """Load a scene file (replaces what the engine holds)."""
    return {"cmd": "load", "scene": scene_json}


def update_request(delta):
    """Replace the scene entries named in `delta` (lights, environment, integrator, ...)."""
    return {"cmd": "update", "scene": delta}


def mesh_material_request(mesh, material):
    """A mesh's material entry, replaced."""
    return {"cmd": "mesh_material", "mesh": mesh, "material": material}


def transform_splats_request(offset, count, matrix):
    """Splats offset .. offset + count - 1 moved by a similarity (4x4, row-major, any sequence)."""
    return {"cmd": "transform_splats", "offset": offset, "count": count, "matrix": [float(x) for x in matrix]}


def splat_materials_request(offset, count, path, channels=None, indices=None):
    """Splats' material values from a float32 file (all channels, or the ones named; all splats of the
    range, or those whose uint32 indices are in the `indices` file)."""
    request = {"cmd": "splat_materials", "offset": offset, "count": count}
    if channels is not None:
        request["channels"] = list(channels)
    request["file"] = path
    if indices is not None:
        request["indices"] = indices
    return request


def render_camera_request(camera, output, aovs, transparent):
    """F12: a render of a scene-file camera entry into `output` (EXR), AOVs as raw float files {aov: path};
    transparent (Film > Transparent): the directly seen world left out, RGB premultiplied by the coverage."""
    return {"cmd": "render", "camera": camera, "output": output, "aovs": aovs, "transparent": bool(transparent)}


def render_view_request(view, spp, first_sample, output, transparent):
    """A viewport pass: `spp` samples of a view (c2w, fx, fy, cx, cy, width, height) from sample
    `first_sample` on (progressive), as raw float RGBA into `output` (transparent: as render_camera_request)."""
    return {"cmd": "render", "view": view, "spp": spp, "transparent": transparent, "first_sample": first_sample,
            "output": output}


def render_progress_text(label, fraction, elapsed):
    """The render's status line: label, percentage, elapsed seconds and the ETA they imply."""
    eta = elapsed * (1.0 - fraction) / fraction if fraction > 0 else 0.0
    return "%s | %.0f%%, %.1f s elapsed, ETA %.1f s" % (label, 100.0 * fraction, elapsed, eta)


# ---------------------------------------------------------------------------------------------
# Command lines of one-off jobs


def render_args(cli_exe, scene_json, output, camera, settings, transparent=False):
    """The `ptir render` command line of F12's image (transparent: Film > Transparent)."""
    args = [cli_exe, "render", scene_json, "-o", output, "--camera", camera, "--spp", settings.spp,
            "--bounces", settings.bounces, "--seed", settings.seed, "--interaction", settings.interaction,
            "--tau-g", "%.9g" % settings.tau_g]
    if settings.threads > 0:
        args += ["--threads", settings.threads]
    if transparent:
        args.append("--transparent")
    return args


# The Optimise panel's time presets (properties.py, `preset`): seconds the whole run may take,
# of which the geometry stage takes at most FIT_SHARE (as `ptir optimize --budget` gives its own,
# pipeline/optimize_budget.h's kFitShare); the inversion gets what the fit leaves (inversion_args).
PRESET_SECONDS = {"DRAFT": 120.0, "GOOD": 600.0, "FINAL": 1800.0}
FIT_SHARE = 0.4


def preset_seconds(settings):
    """The time preset's seconds, or 0 for Custom (the iteration count)."""
    return PRESET_SECONDS.get(getattr(settings, "preset", "CUSTOM"), 0.0)


def fit_args(cli_exe, settings, dataset_dir, split, splats, out_dir, budget):
    """`ptir fit`: the geometry stage of the Optimise flow (at most FIT_SHARE of a time preset's budget)."""
    args = [cli_exe, "fit", "--dataset", dataset_dir, "--split", split, "--gaussians", splats,
            "--out", out_dir, "--iters", settings.fit_iterations, "--seed", settings.seed, "--progress", "json"]
    if budget:  # at most FIT_SHARE of a time preset (the fit's count re-planned as it runs)
        args += ["--budget", "%.0fs" % (FIT_SHARE * budget)]
    if settings.threads > 0:
        args += ["--threads", settings.threads]
    return [str(a) for a in args]


def optimize_args(cli_exe, settings, dataset_dir, split, gaussians, out_dir, fitted, budget, scene_json,
                  optimize_meshes, light=()):
    """`ptir optimize` on photos (a dataset or the scene's cameras), after the flow's own fit when `fitted`.
    The scene file's lamps, emissive meshes and meshes are fixed light and occluders; settings.env "none"
    (scene lights only) removes the environment, any other model learns one for the rest. `light`: the
    known light's arguments (blender/known_world.py: --env-init MAP --fix-env | --env-refine)."""
    args = [cli_exe, "optimize", "--dataset", dataset_dir, "--split", split, "--gaussians", gaussians,
            "--out", out_dir,
            "--bounces", settings.bounces, "--env", settings.env,
            "--env-size", "%dx%d" % (settings.env_width, settings.env_height), "--seed", settings.seed,
            "--fit-iters", 0]  # the flow's own fit stage (above) decides, with its progress
    # The bounce light from the splats' SH where that fit makes them what the photos saw
    # (`ptir optimize --indirect`; its "auto" sees only its own fit stage).
    args += ["--indirect", "field" if fitted else "path"]
    if budget:  # a time preset: what the fit leaves of it, samples and iterations planned by the engine
        args += ["--budget", "%.0fs" % ((1.0 - FIT_SHARE) * budget if fitted else budget)]
    else:  # (a budget takes the engine's automatic batch: patches across the views)
        args += ["--iters", settings.iterations, "--spp", settings.spp,
                 "--views-per-iter", settings.views_per_iter, "--crop", settings.crop]
    if scene_json:
        args += ["--scene", scene_json]
    if optimize_meshes:
        args.append("--optimize-meshes")
    if settings.learn_exposure:
        args.append("--learn-exposure")
    args += list(light)
    return with_common_args(args, settings)


def splats_only_args(cli_exe, settings, splats, out_dir, own_defaults):
    """`ptir optimize --gaussians splats.ply` without --dataset (targets from the splats' own radiance), the
    splats in world space with Blender's +Z as their up (`--up`); own_defaults leaves the iterations, samples
    and crops to the engine's defaults for that path."""
    # Lit by a learnt environment even under Environment None: the scene's lamps take no part in these targets.
    env = "latlong" if settings.env == "none" else settings.env
    args = [cli_exe, "optimize", "--gaussians", splats, "--out", out_dir, "--up", "0,0,1",
            "--bounces", settings.bounces,
            "--env", env, "--env-size", "%dx%d" % (settings.env_width, settings.env_height),
            "--seed", settings.seed]
    if not own_defaults:
        args += ["--iters", settings.iterations, "--spp", settings.spp, "--views-per-iter", settings.views_per_iter,
                 "--crop", settings.crop]
    return with_common_args(args, settings)


def with_common_args(args, settings):
    """args with the switches every optimise run takes, as strings (the progress as JSON lines: cli.py)."""
    args.extend(["--progress", "json"])
    if settings.optimize_metallic:
        args.append("--optimize-metallic")
    if settings.threads > 0:
        args += ["--threads", settings.threads]
    return [str(a) for a in args]


def inversion_args(args, budget_s, fitted, elapsed_s):
    """The inversion's command line once the stages before it took `elapsed_s` seconds: under a
    time preset, its --budget is what the preset has left (a fit that ended early leaves the
    inversion more than 1 - FIT_SHARE), at least 10 s."""
    args = list(args)
    if budget_s and fitted and "--budget" in args:
        args[args.index("--budget") + 1] = "%.0fs" % max(10.0, budget_s - elapsed_s)
    return args


def relightable_overrides(iterations, samples, views, size):
    """Make Relightable's own options for `ptir optimize` without photos (0: the engine's default)."""
    args = []
    for flag, value in (("--iters", iterations), ("--spp", samples), ("--orbit-views", views), ("--orbit-size", size)):
        if value > 0:
            args += [flag, str(value)]
    return args


def estimate_args(args, fit_args):
    """`ptir optimize ... --estimate`: the run's own probe of its first iteration; when a fit runs first,
    the fitted splats do not exist yet, so the probe runs the inversion on the fit's input."""
    args = list(args) + ["--estimate"]
    return with_arg(args, "--gaussians", arg_value(fit_args, "--gaussians")) if fit_args else args


def fit_probe_args(fit_args, out_dir, iterations):
    """The fit's own command line for a few iterations into a scratch folder (its estimate's probe)."""
    return with_arg(with_arg(fit_args, "--out", out_dir), "--iters", iterations) + ["--checkpoint-every", "0", "-q",
                                                                                   "--force"]


def with_arg(args, flag, value):
    """args with the value after `flag` replaced (the flag must be there)."""
    args = list(args)
    args[args.index(flag) + 1] = str(value)
    return args


def arg_value(args, flag):
    """The value after `flag` in args."""
    return args[args.index(flag) + 1]


def run_to_end(args):
    """Runs a one-off `ptir` command to its end without progress (the estimate's probes); returns the
    finished cli.ChildJob: its exit status (job.proc.returncode), its last lines (job.lines, stdout
    and stderr together) and job.error_message()."""
    job = cli.ChildJob(args)
    job.wait()
    return job
