"""bpy.ops.ptir.optimize in blender -b on the tiny dataset of addon_optimize_data.py (run by
test_addon_optimize.py).

    blender -b ... -P addon_optimize_check.py -- MODE DATASET_DIR WORK_DIR [ITERATIONS]

The scene: input.ply imported (no material: the engine's defaults), the floor as a mesh with a
Principled BSDF material (grey, ticked for optimisation), a world with a plain colour.
MODE
  finish   the dataset folder; runs to the end; the splat attributes equal the optimiser's
           gaussians.ply (bit for bit), the floor's Principled BSDF its mesh_materials.json, the world
           has the recovered env.exr as an Environment Texture; prints "OPTIMIZE_STATS: {json}"
  cameras  the same views as scene cameras with a 'ptir_image' property (no dataset folder): finishes
           and writes back
  fail     a dataset whose images are missing: the operator reports the engine's error, and nothing in
           the scene changed
  cancel   a long run cancelled after a few iterations (as Esc / the Cancel button do): nothing changed
  known    Light = Known (the World): the World (an Environment Texture at a quarter of the dataset's
           white sky, Strength 2, a Mapping Z rotation) goes to the engine as --env-init with the
           strength and rotation baked (the rotation checked against a one-column map), --fix-env
           (Known + Refine: --env-refine; Learn: neither); the run's OUT/settings.json records the
           alignment: yaw 0 (a uniform World), exposure 2 from the sky the photos see, and the fixed
           OUT/env.exr is the photos' sky
"""

import json
import os
import sys
import threading
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402

h.enable_addon()
from ptir_blender.blender import compat, material_export, splat_object  # noqa: E402

FLOOR_SHADER = []  # the floor's engine shader before optimising
from ptir_blender.io import splat_ply  # noqa: E402
from ptir_blender.operators import optimize_ops  # noqa: E402

import addon_optimize_data as data  # noqa: E402


def build_scene(dataset):
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=os.path.join(dataset, "input.ply"))
    h.check(r == {"FINISHED"}, "import")
    splats = bpy.context.active_object
    me = bpy.data.meshes.new("floor")
    me.from_pydata([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], [], [(0, 1, 2, 3)])
    floor = bpy.data.objects.new("floor", me)
    bpy.context.scene.collection.objects.link(floor)
    mat = bpy.data.materials.new("Floor Material")
    compat.ensure_nodes(mat)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.9
    me.materials.append(mat)
    mat.ptir.optimize = True
    FLOOR_SHADER[:] = [material_export.material_params(mat)["shader"]]
    world = bpy.data.worlds.new("Plain")
    compat.ensure_nodes(world)
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.05, 0.05, 1.0)
    bpy.context.scene.world = world
    return splats, floor, mat


def snapshot(splats, mat):
    d = splat_object.read_data_from_object(splats)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    world = bpy.context.scene.world
    return {"albedo": d.albedo.copy(), "roughness": d.roughness.copy(), "metallic": d.metallic.copy(),
            "normal": d.normal.copy(), "base": tuple(bsdf.inputs["Base Color"].default_value),
            "rough": bsdf.inputs["Roughness"].default_value,
            "world_nodes": sorted(n.name for n in world.node_tree.nodes), "world": world.name,
            "images": sorted(i.name for i in bpy.data.images)}


def same(a, b):
    for k in a:
        if isinstance(a[k], np.ndarray):
            if not np.array_equal(a[k], b[k]):
                return "%s changed" % k
        elif a[k] != b[k]:
            return "%s changed: %r -> %r" % (k, a[k], b[k])
    return None


def configure(splats, dataset, work, iterations, source="DATASET"):
    s = bpy.context.scene.ptir_optimize
    s.source = source
    s.dataset_dir = dataset
    s.splat_object = splats
    s.iterations = iterations
    s.spp, s.bounces = 4, 1
    s.env, s.env_width, s.env_height = "latlong", 16, 8
    s.optimize_meshes = True
    s.write_environment = True
    s.output_dir = os.path.join(work, "out")
    return s


def run_op():
    try:
        return bpy.ops.ptir.optimize(), ""
    except RuntimeError as e:  # ERROR reports raise in scripts
        return {"CANCELLED"}, str(e)


def check_written_back(splats, mat, out_dir, stats):
    got = splat_object.read_data_from_object(splats)
    res = splat_ply.read_splat_ply(os.path.join(out_dir, "gaussians.ply"))
    for f in ("albedo", "roughness", "metallic"):
        h.check(np.array_equal(getattr(got, f), np.clip(getattr(res, f), 0, 1)),
                "%s attribute equals the optimiser's output" % f)
    h.check(np.max(np.abs(got.normal - res.normal)) < 1e-6, "normals written back (identity transform)")
    mean = got.albedo.mean(axis=0)
    stats["albedo_mean"] = mean.tolist()
    stats["roughness_mean"] = float(got.roughness.mean())
    h.check(mean[0] > 0.4 and mean[0] > mean[1] > mean[2],
            "albedo moved from 0.3 toward the ground truth %s: %s" % (data.ALBEDO_GT, mean))
    mm = json.load(open(os.path.join(out_dir, "mesh_materials.json")))["meshes"]
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    base = tuple(bsdf.inputs["Base Color"].default_value)[:3]
    h.check(np.allclose(base, mm[0]["base_colour"], atol=1e-6), "floor base colour %s vs %s" % (base, mm[0]))
    h.check(abs(bsdf.inputs["Roughness"].default_value - mm[0]["roughness"]) < 1e-6, "floor roughness")
    stats["floor_base"] = list(base)
    # The rest of the Principled BSDF stays what the engine rendered it with, in this Blender's model
    # (v2: IOR, Specular IOR Level, Specular Tint colour, Diffuse Roughness; v1: Specular, Specular Tint).
    after = material_export.material_params(mat)
    for k, v in material_export.model_fields(compat.principled_model()).items():
        h.check(np.allclose(after[k], v), "floor %s %s after the write-back, expected %s" % (k, after[k], v))
    h.check(after["shader"] == FLOOR_SHADER[0], "floor shader %s, was %s" % (after["shader"], FLOOR_SHADER[0]))
    h.check(base[1] > base[0], "the green floor recovered greener than red: %s" % (base,))
    world = bpy.context.scene.world
    env = world.node_tree.nodes.get("PTIR Environment")
    h.check(env is not None and env.image is not None, "the world has the recovered Environment Texture")
    h.check(env.outputs["Color"].links[0].to_node.type == "BACKGROUND", "linked to the Background")
    h.check(tuple(env.image.size) == (16, 8), "env image size %s" % (tuple(env.image.size),))


def world_with_texture(value, size=(16, 8), strength=2.0, rotation_z=0.4):
    """A World whose Background takes a float image (each texel `value`, or a (h, w, 3) array) through a
    Mapping node turning it by rotation_z."""
    img = bpy.data.images.new("known_sky", size[0], size[1], float_buffer=True)
    rgb = np.broadcast_to(np.asarray(value, np.float32), (size[1], size[0], 3))
    px = np.concatenate([rgb[::-1], np.ones((size[1], size[0], 1), np.float32)], axis=2)  # rows bottom-up
    img.pixels.foreach_set(px.ravel())
    world = bpy.data.worlds.new("Known")
    compat.ensure_nodes(world)
    nodes, links = world.node_tree.nodes, world.node_tree.links
    tex = nodes.new("ShaderNodeTexEnvironment")
    tex.image = img
    mapping, coords = nodes.new("ShaderNodeMapping"), nodes.new("ShaderNodeTexCoord")
    mapping.inputs["Rotation"].default_value[2] = rotation_z
    links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    links.new(tex.outputs["Color"], nodes["Background"].inputs["Color"])
    nodes["Background"].inputs["Strength"].default_value = strength
    bpy.context.scene.world = world
    return world


def check_known_light(splats, dataset, work, iterations, stats):
    from ptir_blender.blender import known_world, optimize_job
    engine = h.native_module()  # (the build's: the add-on ships none in the tests)
    cli = os.environ.get("PTIR_CLI", "ptir")
    # The rotation baked as the engine reads a Mapping node (lights/environment.h): what the texture holds
    # at direction d shows in the world at Rz(-rotation_z) d, so column 0 (u = 0, toward -x) turned by
    # 90 degrees shows toward Rz(-90) (-x) = +y, u = 0.25: column 4 of 16.
    col = np.zeros((8, 16, 3), np.float32)
    col[:, 0] = 1.0
    turned = known_world.rotate_yaw(col, np.pi / 2)
    h.check(np.argmax(turned[0, :, 0]) == 4 and abs(turned.sum() - col.sum()) < 1e-4,
            "a 90-degree Mapping rotation moves column 0 to 4: %s" % turned[0, :, 0])
    world_with_texture(0.25)  # x Strength 2: half the photos' white sky
    s = configure(splats, dataset, work, iterations)
    s.optimize_meshes = False
    expected = {"LEARN": [], "KNOWN": ["--fix-env"], "KNOWN_REFINE": ["--env-refine"]}
    for light, flags in expected.items():
        s.light = light
        job_dir = os.path.join(work, "job_" + light)
        os.makedirs(job_dir, exist_ok=True)
        args = optimize_job.prepare(bpy.context, s, job_dir, cli).args
        for f in ("--fix-env", "--env-refine"):
            h.check((f in args) == (f in flags), "Light %s: %s %s in %s" % (light, f, "not" * (f not in flags), args))
        h.check(("--env-init" in args) == (light != "LEARN"), "Light %s: --env-init in %s" % (light, args))
        if light != "LEARN":
            known = engine.read_image(args[args.index("--env-init") + 1])
            h.check(np.allclose(known[:, :, :3], 0.5, atol=1e-3), "strength 2 x 0.25 baked: %s" % known.mean())
    s.light = "KNOWN"
    result, msg = run_op()
    h.check(result == {"FINISHED"}, "optimize with the known World returned %s %s" % (result, msg))
    out = os.path.join(work, "out")
    rec = json.load(open(os.path.join(out, "settings.json")))["env_align"]
    h.check(rec["mode"] == "auto" and rec["yaw_deg"] == 0.0, "the World's orientation kept: yaw 0 (%s)" % rec)
    # The photos see the sky around the sphere: its level is the exposure (twice the World's), and the
    # fixed light is the photos' white sky (to their 8-bit steps).
    h.check(rec["scale_from"] == "background" and np.allclose(rec["scale"], 2.0, rtol=0.01),
            "the exposure from the background: %s" % rec)
    env = engine.read_image(os.path.join(out, "env.exr"))
    h.check(np.allclose(env[:, :, :3], 1.0, rtol=0.01), "the fixed light is the photos' sky: %s" % env.mean(axis=(0, 1)))
    stats["env_align"] = {k: rec[k] for k in ("mode", "yaw_deg", "scale", "scale_from", "score")}
    stats["albedo_mean"] = splat_object.read_data_from_object(splats).albedo.mean(axis=0).tolist()


def main():
    mode, dataset, work = h.argv()[:3]
    iterations = int(h.argv()[3]) if len(h.argv()) > 3 else 60
    splats, floor, mat = build_scene(dataset)
    before = snapshot(splats, mat)
    stats = {"mode": mode}
    if mode == "finish":
        configure(splats, dataset, work, iterations)
        t0 = time.perf_counter()
        result, msg = run_op()
        stats["seconds"] = time.perf_counter() - t0
        h.check(result == {"FINISHED"}, "optimize returned %s %s" % (result, msg))
        check_written_back(splats, mat, os.path.join(work, "out"), stats)
        h.check(bpy.context.scene.ptir_optimize.status.startswith("done"), "status line")
    elif mode == "cameras":
        frames = json.load(open(os.path.join(dataset, "transforms_train.json")))["frames"]
        for i, fr in enumerate(frames):
            cam = bpy.data.objects.new("view_%d" % i, bpy.data.cameras.new("view_%d" % i))
            cam.data.sensor_fit = "HORIZONTAL"
            cam.data.lens = 0.5 * cam.data.sensor_width / np.tan(0.5 * data.FOV_X)
            from mathutils import Matrix
            cam.matrix_world = Matrix(fr["transform_matrix"])
            cam["ptir_image"] = os.path.join(dataset, fr["file_path"] + ".png")
            bpy.context.scene.collection.objects.link(cam)
        before = snapshot(splats, mat)
        configure(splats, "", work, iterations, source="CAMERAS")
        result, msg = run_op()
        h.check(result == {"FINISHED"}, "optimize from scene cameras returned %s %s" % (result, msg))
        check_written_back(splats, mat, os.path.join(work, "out"), stats)
    elif mode == "fail":
        broken = os.path.join(work, "broken")
        os.makedirs(broken, exist_ok=True)
        with open(os.path.join(broken, "transforms_train.json"), "w") as f:
            json.dump({"camera_angle_x": 0.9, "w": 32, "h": 32, "frames": [{"file_path": "./train/missing",
                                                          "transform_matrix": np.eye(4).tolist()}]}, f)
        configure(splats, broken, work, iterations)
        result, msg = run_op()
        h.check(result == {"CANCELLED"}, "a failed run is cancelled (%s)" % result)
        h.check("Optimisation failed" in msg and "train/missing" in msg, "the engine's error is reported: %s" % msg)
        stats["message"] = msg
        problem = same(before, snapshot(splats, mat))
        h.check(problem is None, "a failed run changed the scene: %s" % problem)
        # no dataset at all: refused before starting
        bpy.context.scene.ptir_optimize.dataset_dir = os.path.join(work, "nowhere")
        result, msg = run_op()
        h.check(result == {"CANCELLED"} and "does not exist" in msg, msg)
    elif mode == "cancel":
        configure(splats, dataset, work, 100000)
        timer = threading.Timer(4.0, optimize_ops.request_cancel)
        timer.start()
        t0 = time.perf_counter()
        result, msg = run_op()
        stats["seconds"] = time.perf_counter() - t0
        h.check(result == {"CANCELLED"}, "a cancelled run returns CANCELLED (%s)" % result)
        h.check(stats["seconds"] < 60, "cancelled promptly (%.1f s)" % stats["seconds"])
        problem = same(before, snapshot(splats, mat))
        h.check(problem is None, "a cancelled run changed the scene: %s" % problem)
        h.check(bpy.context.scene.ptir_optimize.status == "cancelled", bpy.context.scene.ptir_optimize.status)
    elif mode == "known":
        check_known_light(splats, dataset, work, iterations, stats)
    else:
        raise SystemExit("unknown mode " + mode)
    h.check(not bpy.context.scene.ptir_optimize.running, "no job left running")
    print("OPTIMIZE_STATS: " + json.dumps(stats), flush=True)


h.run(main)
