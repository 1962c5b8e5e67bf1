"""The bundled sample object and its splat twin, with N independent Cycles renders.

Run inside Blender 3.4, headless:

    blender -b --factory-startup -noaudio --python-exit-code 1 -P tests/blender/splat_twin_scene.py -- \
        --out-dir DIR [--res 128] [--samples 64] [--seeds 1 2 3 4] [--bounces 2] [--subdiv 2]

Builds the sample object (scripts/dataset/scene.py: Suzanne, Catmull-Clark, smooth
shaded, on a box pedestal; Principled materials), lights it with the dataset
maker's "studio" environment, looks at it from the first test pose of
scripts/make_dataset.py, and writes
    DIR/cycles_seed<S>.npy   Cycles (CPU) renders, float32 H x W x 3 linear, one per seed
                             (settings of scripts/dataset/scene.py setup_cycles: no denoising,
                             no adaptive sampling, no clamping, Box 1 px, every bounce limit =
                             --bounces; opaque film: the environment is seen behind)
    DIR/export/scene.json    the mesh scene (addon scene_export)
    DIR/gaussians.ply        the object as flat Gaussians with its true materials and face
                             normals (make_dataset.py's oracle: one Gaussian per polygon)
and prints one line "PTIR_SPLAT_TWIN_JSON: {...}".
"""

import json
import os
import sys
import time

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(REPO, "scripts"))
sys.path.insert(0, os.path.join(REPO, "addon"))

import blender_kit as kit  # noqa: E402
import make_dataset  # noqa: E402
from dataset import envmaps, exr, scene as dscene, splat  # noqa: E402
from ptir_blender.blender import scene_export  # noqa: E402


def parse_args():
    return kit.scene_script_args(samples=64, seeds=[1, 2, 3, 4],
                                 extra=lambda ap: ap.add_argument("--subdiv", type=int, default=2))


def main():
    a = parse_args()
    os.makedirs(a.out_dir, exist_ok=True)
    dscene.clear_scene()
    objs = dscene.build_sample_object(subdiv=a.subdiv)
    scene = bpy.context.scene
    env_path = os.path.join(a.out_dir, "studio.exr")
    exr.write_exr(env_path, envmaps.make_envmap("studio", 128, 64))
    kit.set_environment(scene, env_path)
    cam = dscene.camera_object(scene)
    from mathutils import Matrix
    cam.matrix_world = Matrix(make_dataset.test_poses(8, 4.0)[0].tolist())
    dscene.setup_cycles(scene, a.res, a.samples, a.bounces, a.threads)
    scene.render.film_transparent = False
    scene.render.use_compositing = False
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    seconds = []
    for s in a.seeds:
        scene.cycles.seed = s
        path = os.path.join(a.out_dir, "cycles_seed%d.exr" % s)
        scene.render.filepath = path
        t0 = time.time()
        bpy.ops.render.render(write_still=True)
        seconds.append(time.time() - t0)
        img = bpy.data.images.load(path, check_existing=False)
        px = np.array(img.pixels[:], np.float32).reshape(a.res, a.res, 4)[::-1, :, :3]
        bpy.data.images.remove(img)
        np.save(os.path.join(a.out_dir, "cycles_seed%d.npy" % s), np.ascontiguousarray(px))
    g, _ = make_dataset.object_splats(objs)
    splat.write_gaussians_ply(os.path.join(a.out_dir, "gaussians.ply"), g, oracle=True)
    scene_path = scene_export.export_scene(scene, os.path.join(a.out_dir, "export"),
                                           integrator={"bounces": a.bounces})
    print("PTIR_SPLAT_TWIN_JSON: " + json.dumps({"scene": scene_path, "gaussians": int(len(g["position"])),
                                                  "cycles_seconds": seconds, "samples": a.samples}), flush=True)


main()
