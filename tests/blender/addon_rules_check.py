"""The add-on's error rule and transform rule inside Blender (run by test_addon_rules.py).

    blender -b --factory-startup -noaudio --python-exit-code 1 -P addon_rules_check.py -- MODE TMPDIR

MODE errors: every add-on error derives from errors.PtirError, and a mesh the engine cannot be given
  (a vertex at NaN: io/mesh_ply.py raises MeshPlyError while the scene is exported) is reported by
  the render engine (F12) and by the optimise operator with the message naming the file and the
  problem; no traceback, the scene unchanged.
MODE transform: one object transform with a non-uniform scale and a rotation, on
  (a) a splat object: Export folds it into the PLY with covariance A Sigma A^T (checked against a
      float64 computation here), and F12 renders it;
  (b) an empty whose "ptir_gaussians" property names the same PLY: F12 renders it (the engine's
      scene-file transform refuses non-uniform scales; the add-on folds them itself) to the very
      image of (a) -- one rule on both routes;
  (c) optimising the splat object against a dataset folder is refused with a clear message (the
      dataset's cameras cannot follow a non-uniform scale), the scene unchanged.
Prints "RULES_STATS: {json}".
"""

import json
import math
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402
import addon_common as ac  # noqa: E402
import blender_kit as kit  # noqa: E402  (scripts/, put on sys.path by addon_common)

h.enable_addon()
from ptir_blender import errors  # noqa: E402
from ptir_blender.blender import optimize_job, scene_export, splat_object  # noqa: E402
from ptir_blender.io import cli, dataset_file, mesh_ply, scene_file, splat_ply, splat_transform  # noqa: E402
from ptir_blender.io import surface_splats  # noqa: E402


def scene_state():
    objs = sorted((o.name, tuple(round(x, 6) for x in np.array(o.matrix_world).ravel())) for o in bpy.data.objects)
    return (objs, sorted(m.name for m in bpy.data.meshes), sorted(m.name for m in bpy.data.materials),
            sorted(i.name for i in bpy.data.images), sorted(w.name for w in bpy.data.worlds))


def clear():
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)


def small_scene():
    """A camera looking at the origin, a grey world, the PTIR engine at 32 x 32, 4 spp, 1 bounce."""
    scene = bpy.context.scene
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location = (0.0, -6.0, 0.0)
    cam.rotation_euler = (math.radians(90.0), 0.0, 0.0)
    scene.camera = cam
    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    kit.set_world_colour(scene, (0.5, 0.5, 0.5))  # (5.0 has no node-less worlds)
    scene.render.engine = "PTIR"
    scene.render.resolution_x = scene.render.resolution_y = 32
    scene.render.resolution_percentage = 100
    s = scene.ptir_render
    s.spp, s.bounces, s.seed = 4, 1, 5
    return scene


def render(path):
    """F12 with the scene's engine; the Render Result as float32 (h, w, 4), rows bottom-up."""
    bpy.ops.render.render()
    settings = bpy.context.scene.render.image_settings
    settings.file_format, settings.color_depth, settings.color_mode = "OPEN_EXR", "32", "RGBA"
    bpy.data.images["Render Result"].save_render(path)
    return kit.read_pixels(path)


# ------------------------------------------------------------------ errors

def check_hierarchy():
    raised = {mesh_ply: "MeshPlyError", splat_ply: "SplatPlyError", surface_splats: "SplatError",
              splat_transform: "TransformError", scene_file: "SceneFileError", dataset_file: "DatasetError",
              cli: "JobError", splat_object: "SplatObjectError", scene_export: "ExportError",
              optimize_job: "OptimizeError"}
    for module, name in raised.items():
        cls = getattr(module, name)
        h.check(issubclass(cls, errors.PtirError), "%s.%s derives from PtirError" % (module.__name__, name))
    found = [c for c in vars(errors).values() if isinstance(c, type) and issubclass(c, Exception)]
    h.check(all(issubclass(c, errors.PtirError) for c in found) and len(found) == len(raised) + 1,
            "errors.py holds PtirError and the %d add-on errors: %s" % (len(raised), [c.__name__ for c in found]))
    return len(raised)


def nan_mesh():
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, 0.0))
    cube = bpy.context.active_object
    cube.name = "Broken"
    cube.data.vertices[0].co = (float("nan"), 0.0, 0.0)
    return cube


def failed_optimise(tmp, obj):
    """Runs bpy.ops.ptir.optimize on obj against a (view-less) dataset folder; it must fail with an
    error report and leave the scene unchanged. Returns the message."""
    data = os.path.join(tmp, "dataset")
    os.makedirs(data, exist_ok=True)
    with open(os.path.join(data, "transforms_train.json"), "w") as f:
        json.dump({"camera_angle_x": 0.7, "frames": []}, f)
    s = bpy.context.scene.ptir_optimize
    s.source, s.dataset_dir, s.splat_object = "DATASET", data, obj
    before = scene_state()
    try:
        r = bpy.ops.ptir.optimize()
        raise AssertionError("optimise did not fail (%s)" % r)
    except RuntimeError as e:  # an ERROR report raises in scripts
        msg = str(e)
    h.check(scene_state() == before and not s.running, "the failed optimise changed the scene: %s" % msg)
    return msg


def check_errors(tmp):
    stats = {"error_classes": check_hierarchy()}
    clear()
    small_scene()
    nan_mesh()
    before = scene_state()
    # F12: the engine reports the exporter's MeshPlyError (it used to escape as a traceback).
    print("RENDER_BEGIN", flush=True)
    try:
        bpy.ops.render.render()
    except RuntimeError as e:  # an error report may raise in scripts
        print("render raised: %s" % e)
    print("RENDER_END", flush=True)
    h.check(scene_state() == before, "the render changed the scene")

    # Optimise: the same scene export fails inside the operator, reported, nothing changed.
    raw = ac.random_raw(200, sh_rest=0, seed=21)
    ply = ac.write_ply(os.path.join(tmp, "splats.ply"), raw)
    h.check(bpy.ops.import_scene.gaussian_splat_ply(filepath=str(ply)) == {"FINISHED"}, "import")
    msg = failed_optimise(tmp, bpy.data.objects["splats"])
    h.check("mesh has non-finite vertex coordinates" in msg and "mesh_Broken.ply" in msg,
            "optimise message names the file and the problem: %s" % msg)
    stats["optimize_message"] = msg.strip().splitlines()[-1]
    return stats


# ------------------------------------------------------------------ transform

def covariance(d):
    r = splat_transform.quat_to_matrix(d.rotation)
    return np.einsum("nij,nj,nkj->nik", r, d.scale.astype(np.float64) ** 2, r)


def compact_raw(n, seed):
    """Splats in a ball of radius ~0.5 at the origin, opaque enough to see."""
    raw = ac.random_raw(n, sh_rest=0, material=True, seed=seed)
    for c in "xyz":
        raw[c] = raw[c] * 0.12
    for k in range(3):
        raw["scale_%d" % k] = raw["scale_%d" % k] * 0.25 - 2.5
    raw["opacity"] = np.abs(raw["opacity"]) + 1.0
    return raw


def place(obj):
    obj.location = (0.2, 0.0, -0.1)
    obj.rotation_euler = (0.4, -0.3, 0.9)
    obj.scale = (1.0, 2.5, 0.5)
    bpy.context.view_layer.update()


def check_transform(tmp):
    stats = {}
    clear()
    scene = small_scene()
    ply = ac.write_ply(os.path.join(tmp, "capture.ply"), compact_raw(400, 22))
    h.check(bpy.ops.import_scene.gaussian_splat_ply(filepath=str(ply)) == {"FINISHED"}, "import")
    obj = bpy.data.objects["capture"]
    place(obj)
    m = np.array(obj.matrix_world, np.float64)
    h.check(not splat_transform.is_similarity(m), "test design: a non-uniform scale")

    # (a) export folds it: covariance A Sigma A^T, positions A p + t
    out = os.path.join(tmp, "world.ply")
    h.check(bpy.ops.export_scene.gaussian_splat_ply(filepath=out) == {"FINISHED"}, "export")
    w = splat_ply.read_splat_ply(out)
    local = splat_ply.read_splat_ply(str(ply))
    a = m[:3, :3]
    want = np.einsum("ij,njk,lk->nil", a, covariance(local), a)
    rel = np.max(np.abs(covariance(w) - want) / np.max(np.abs(want), axis=(1, 2), keepdims=True))
    stats["covariance_max_rel_err"] = float(rel)
    h.check(rel < 1e-5, "exported covariance = A Sigma A^T (max relative error %g)" % rel)
    pos = local.position.astype(np.float64) @ a.T + m[:3, 3]
    h.check(np.max(np.abs(w.position - pos)) < 1e-5, "exported positions = A p + t")
    img_object = render(os.path.join(tmp, "object.exr"))
    covered = float(np.mean(img_object[..., :3].sum(-1) < 1.4))  # the grey world sums to 1.5
    stats["object_pixels_darker_than_world"] = covered
    h.check(0.02 < covered < 0.9, "the splats show in the F12 render (%.3f of the pixels)" % covered)

    # (b) the same PLY by reference, same transform: rendered, to the same image
    obj.hide_render = True
    holder = bpy.data.objects.new("Holder", None)
    scene.collection.objects.link(holder)
    holder["ptir_gaussians"] = str(ply)
    place(holder)
    folder = os.path.join(tmp, "export")
    path = scene_export.export_scene(bpy.context, folder)
    entry = json.load(open(path))["gaussians"][0]
    h.check("transform" not in entry and os.path.isfile(os.path.join(folder, entry["file"])),
            "a non-uniform transform is folded into the exported PLY: %s" % entry)
    img_holder = render(os.path.join(tmp, "holder.exr"))
    diff = float(np.max(np.abs(img_holder - img_object)))
    stats["holder_vs_object_max_abs"] = diff
    h.check(diff == 0.0, "the referenced PLY renders like the splat object (max diff %g)" % diff)
    holder.scale = (1.5, 1.5, 1.5)  # a similarity stays a reference with the engine's transform
    bpy.context.view_layer.update()
    entry = json.load(open(scene_export.export_scene(bpy.context, folder)))["gaussians"][0]
    h.check("transform" in entry and entry["file"] == str(ply), "a similarity is passed by reference: %s" % entry)
    bpy.data.objects.remove(holder)
    obj.hide_render = False

    # (c) optimise against a dataset: refused, clearly, nothing changed
    msg = failed_optimise(tmp, obj)
    h.check("non-uniform scale" in msg and "'capture'" in msg, "optimise refusal names object and reason: %s" % msg)
    stats["optimize_message"] = msg.strip().splitlines()[-1]
    return stats


def main():
    mode, tmp = h.argv()[:2]
    stats = check_errors(tmp) if mode == "errors" else check_transform(tmp)
    print("RULES_STATS: %s" % json.dumps(stats), flush=True)


h.run(main)
