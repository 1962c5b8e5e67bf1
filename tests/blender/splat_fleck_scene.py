"""A concave scene and its splat twin as a trainer would write it (no normals), with Cycles renders.

Run inside Blender 3.4, headless:

    blender -b --factory-startup -noaudio --python-exit-code 1 -P tests/blender/splat_fleck_scene.py -- \
        --out-dir DIR [--res 128] [--samples 256] [--seeds 1] [--bounces 2]

The scene (issue #36's case): a torus (96 x 48 segments, smooth shaded) tilted 50 degrees toward
the camera so that its inner ring is seen, and a subdivided Suzanne (Catmull-Clark level 2, smooth)
over it: concave parts (the inner ring, the eye sockets, under the chin). Uniform Principled
materials, the dataset maker's "studio" environment, the first test pose of scripts/make_dataset.py.
Writes
    DIR/cycles_seed<S>.npy   Cycles (CPU) renders, float32 H x W x 3 linear (no denoising, adaptive
                             sampling or clamping, Box 1 px, every bounce limit = --bounces, opaque film)
    DIR/export/scene.json    the mesh scene (the add-on's scene_export)
    DIR/gaussians.ply        the objects as flat Gaussians (one per polygon) with their true materials
                             and zero normals (the INRIA layout a trainer writes: the engine must orient them)
    DIR/addon_f12.npy        with --addon-f12: the PLY imported by the add-on (File > Import), the meshes
                             hidden, F12 with the PTIR engine at --samples (float32 H x W x 3 linear)
and prints one line "PTIR_SPLAT_FLECK_JSON: {...}".
"""

import json
import math
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
from dataset import envmaps, exr, scene as dscene  # noqa: E402
from ptir_blender.blender import scene_export  # noqa: E402
from ptir_blender.io import surface_splats  # noqa: E402


def parse_args():
    def addon_f12(ap):
        ap.add_argument("--addon-f12", action="store_true",
                        help="then import gaussians.ply with the add-on, hide the meshes and render F12 with the "
                             "PTIR engine at --samples: DIR/addon_f12.npy")
    return kit.scene_script_args(seeds=[1], extra=addon_f12)


def addon_f12(scene, out_dir, samples, bounces):
    """The add-on's path: File > Import the splat PLY, the meshes hidden, F12 with the PTIR engine."""
    sys.path.insert(0, HERE)
    import addon_blender_harness as h
    h.enable_addon()
    for o in dscene.object_meshes():
        o.hide_render = True
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=os.path.join(out_dir, "gaussians.ply"), frame=False)
    assert r == {"FINISHED"}, r
    scene.render.engine = "PTIR"
    s = scene.ptir_render
    s.spp, s.bounces, s.seed = samples, bounces, 7
    bpy.ops.render.render()
    path = os.path.join(out_dir, "addon_f12.exr")
    settings = scene.render.image_settings
    settings.file_format, settings.color_depth, settings.color_mode = "OPEN_EXR", "32", "RGBA"
    bpy.data.images["Render Result"].save_render(path)
    np.save(os.path.join(out_dir, "addon_f12.npy"), np.ascontiguousarray(kit.read_pixels(path)[::-1, :, :3]))


def build_objects():
    """Torus and Suzanne (head and eyes), smooth shaded, normalised to a radius of 1.25."""
    coll = bpy.data.collections.new(dscene.OBJECT_COLLECTION)
    bpy.context.scene.collection.children.link(coll)
    torus_mat = dscene.principled_material("torus", (0.75, 0.45, 0.2), 0.45)
    head_mat = dscene.principled_material("head", (0.6, 0.6, 0.65), 0.35)
    eyes_mat = dscene.principled_material("eyes", (0.15, 0.3, 0.8), 0.25)
    bpy.ops.mesh.primitive_torus_add(major_radius=0.8, minor_radius=0.3, major_segments=96, minor_segments=48,
                                     rotation=(math.radians(-50.0), 0.0, 0.0))
    torus = bpy.context.active_object
    torus.name = "torus"
    torus.data.materials.append(torus_mat)
    for poly in torus.data.polygons:
        poly.use_smooth = True
    bpy.ops.mesh.primitive_monkey_add(size=1.3, location=(0.0, 0.3, 1.05))
    parts = kit.separate_suzanne({"head": head_mat, "eyes": eyes_mat}.get, 2, smooth_shading=True)
    objs = [torus] + parts
    for o in objs:
        for c in list(o.users_collection):
            c.objects.unlink(o)
        coll.objects.link(o)
    dscene.normalise_objects(objs, 1.25)
    bpy.ops.object.select_all(action="SELECT")
    bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)
    bpy.ops.object.select_all(action="DESELECT")
    return objs


def main():
    a = parse_args()
    os.makedirs(a.out_dir, exist_ok=True)
    dscene.clear_scene()
    objs = build_objects()
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
    surface_splats.write_gaussians_ply(os.path.join(a.out_dir, "gaussians.ply"), g, opacity=0.95,
                                       albedo=g["albedo"], roughness=g["roughness"], metallic=g["metallic"],
                                       write_normals=False, display_colour=g["display_colour"],
                                       comment="PTIR test: flat Gaussians of the mesh, true materials, no normals")
    scene_path = scene_export.export_scene(scene, os.path.join(a.out_dir, "export"),
                                           integrator={"bounces": a.bounces})
    if a.addon_f12:
        addon_f12(scene, a.out_dir, a.samples, a.bounces)
    print("PTIR_SPLAT_FLECK_JSON: " + json.dumps({"scene": scene_path, "gaussians": int(len(g["position"])),
                                                   "cycles_seconds": seconds, "samples": a.samples}), flush=True)


main()
