"""Builds the one-click optimise sample: a .blend whose Optimise panel is ready to run.

    blender -b --factory-startup -noaudio --python-exit-code 1 \
        -P sample_blends/make_optimise_sample.py -- --dataset out/sample_dataset \
        --out out/optimise_sample.blend [--iters 400] [--spp 16] [--bounces 2] [--no-estimate]

`make demo` (scripts/demo.sh) makes it beside its dataset: out/optimise_sample.blend next to
out/sample_dataset/ (the Cycles renders of sample_blends/sample_object.blend, with known answers).
Generated rather than bundled: the dataset is made on the user's machine anyway, and the
estimate below must be measured there.

Contents:
  - "Sample Splats": the dataset's gaussians.ply imported (identity transform: the dataset's
    cameras are in its frame), without materials (the engine's defaults, albedo 0.3)
  - a camera at the dataset's first test view, render engine PTIR at the dataset's resolution x 2
  - the world: the dataset's training environment (envmaps/<train_env>.exr), so the viewport and F12
    show the object as the photos do before anything is recovered
  - the Optimise panel: source Dataset, folder "//<relative path>" (relative to the .blend: the pair
    can be moved together), the splat object, the demo's settings (400 iterations x 16 spp x 2
    bounces, lat-long 128 x 64)
  - unless --no-estimate: the duration estimate measured here (blender/optimize_estimate.py), saved
    with the file so that the panel shows it on opening
The add-on is enabled from the repository (addon/).
"""

import argparse
import json
import os
import sys

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(REPO, "scripts"))

import blender_kit as kit  # noqa: E402  (also puts the add-on on sys.path)


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser(prog="make_optimise_sample.py")
    ap.add_argument("--dataset", required=True, help="a dataset made by scripts/make_dataset.py")
    ap.add_argument("--out", required=True, help="the .blend to write")
    ap.add_argument("--iters", type=int, default=400)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--bounces", type=int, default=2)
    ap.add_argument("--no-estimate", action="store_true", help="do not measure the duration estimate")
    return ap.parse_args(argv)


def enable_addon():
    import addon_utils
    if addon_utils.enable("ptir_blender", default_set=True, handle_error=None) is None:
        raise SystemExit("cannot enable ptir_blender from %s" % os.path.join(REPO, "addon"))


def main():
    a = args()
    dataset = os.path.abspath(a.dataset)
    out = os.path.abspath(a.out)
    with open(os.path.join(dataset, "dataset.json")) as f:
        info = json.load(f)
    enable_addon()
    scene = kit.reset_scene(images=True)
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=os.path.join(dataset, info.get("splat", "gaussians.ply")),
                                                frame=False)
    if r != {"FINISHED"}:
        raise RuntimeError("import of %s failed" % dataset)
    obj = bpy.context.active_object
    obj.name = "Sample Splats"

    with open(os.path.join(dataset, "transforms_test.json")) as f:
        test = json.load(f)
    from mathutils import Matrix
    cam_data = bpy.data.cameras.new("Camera")
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.angle = float(test["camera_angle_x"])
    cam = bpy.data.objects.new("Camera", cam_data)
    scene.collection.objects.link(cam)
    cam.matrix_world = Matrix(test["frames"][0]["transform_matrix"])
    scene.camera = cam
    w, h = info["resolution"]
    scene.render.resolution_x, scene.render.resolution_y = 2 * w, 2 * h
    scene.render.engine = "PTIR"
    env = info["envmaps"][info["train_env"]]
    kit.set_environment(scene, os.path.join(dataset, env), sampling=None)

    s = scene.ptir_optimize
    s.source = "DATASET"
    rel = os.path.relpath(dataset, os.path.dirname(out)).replace(os.sep, "/")
    s.dataset_dir = "//" + rel + "/"
    s.splat_object = obj
    s.iterations, s.spp, s.bounces = a.iters, a.spp, a.bounces
    s.env, s.env_width, s.env_height = "latlong", 128, 64
    os.makedirs(os.path.dirname(out), exist_ok=True)
    bpy.context.preferences.filepaths.save_version = 0  # no .blend1 beside it
    # Saved first: the dataset path is relative to the .blend, and the estimate resolves it; the
    # environment image's path is made relative too.
    bpy.ops.wm.save_as_mainfile(filepath=out)
    bpy.ops.file.make_paths_relative()
    bpy.ops.wm.save_mainfile()
    if not a.no_estimate:
        from ptir_blender.blender import optimize_estimate
        from ptir_blender.operators import render_engine
        optimize_estimate.measure(bpy.context, s, render_engine.cli_path())
        print("make_optimise_sample: estimated %s (%.2f s/iteration, %.1f s setup)"
              % (optimize_estimate.duration_text(optimize_estimate.seconds(bpy.context, s)), s.estimate_s_per_iter,
                 s.estimate_setup_s))
        bpy.ops.wm.save_mainfile()
    print("make_optimise_sample: wrote %s (dataset %s, %d splats)" % (out, s.dataset_dir, len(obj.data.vertices)))


kit.run_main(main, "make_optimise_sample.py")
