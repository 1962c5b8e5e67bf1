"""Builds the Cycles comparison scenes, renders the Cycles references, exports them.

Run inside Blender 3.4, headless:

    blender -b --factory-startup -noaudio --python-exit-code 1 \
        -P tests/blender/cycles_compare_scenes.py -- --out-dir DIR --jobs cornell glossy_m0 \
        [--env env.exr] [--samples 256] [--seeds 1 2] [--res 128]

For each job it builds the scene by script, renders it with Cycles (CPU) once per
seed and saves each render as DIR/JOB/cycles_seed<S>.npy (float32, H x W x 3,
linear, row 0 = top), exports the scene with
addon/ptir_blender/blender/scene_export.py to DIR/JOB/export/scene.json, and
prints one line "PTIR_CYCLES_COMPARE_JSON: {...}" (timings, settings).

Jobs
  cornell     Cornell box: five walls (white, red left, green right), a tall and a
              short box, a 0.6 x 0.5 m rectangular area light (40 W) just under the
              ceiling facing down (visible to the camera in both renderers), world
              black; bounces 3.
  glossy_m0   a sphere (icosphere, 20480 flat faces, radius 0.5) with roughness 0.3,
              metallic 0, base colour (0.8, 0.2, 0.1) on a grey plane, lit only by
              the environment map --env (Mapping Z rotation 0.6 rad); bounces 2.
  glossy_m1   the same with metallic 1, base colour (0.9, 0.7, 0.3).

Cycles settings that make it compute the same estimator's expectation as ours:
denoising off, adaptive sampling off, clamping off (direct and indirect), Filter
Glossy 0 (it would blur indirect glossy), light sampling threshold 0 (no light
culling), caustics on (reflective and refractive; we do not filter them), every
bounce limit = max bounces, pixel filter Box of width 1 px (= our uniform jitter
inside the pixel; --pixel-filter/--filter-width change it, and the export carries it), view transform Standard (EXR is linear anyway), Environment
Texture interpolation Closest (= our nearest lookup), flat shading, shadow
terminator offsets 0. Blender 3.4 has no light tree.

Materials: every surface uses the "matched" material of tests/blender/disney_match.py
(Lambert diffuse + GGX glossy whose colours reproduce our simplified Disney BRDF's
directional albedo for every viewing angle); the exporter reads the intended
(base colour, roughness, metallic) from the material's ptir_* custom properties.
"""

import argparse
import json
import math
import os
import sys
import time

import bpy
import numpy as np
from mathutils import Vector

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(REPO, "scripts"))

import blender_kit as kit  # noqa: E402  (also puts the add-on on sys.path)
import disney_match  # noqa: E402
from ptir_blender.blender import scene_export  # noqa: E402

ENV_ROTATION_Z = 0.6


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser()
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("--jobs", nargs="+", default=["cornell", "glossy_m0", "glossy_m1"])
    ap.add_argument("--env", default=None, help="lat-long EXR for the glossy jobs")
    ap.add_argument("--samples", type=int, default=256)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--pixel-filter", default="BOX", choices=["BOX", "GAUSSIAN", "BLACKMAN_HARRIS"],
                    help="Cycles pixel filter (default Box, 1 px: see the module notes)")
    ap.add_argument("--filter-width", type=float, default=1.0)
    return ap.parse_args(argv)


# ---------------------------------------------------------------- scene basics

def reset_scene():
    return kit.reset_scene(images=True)


def setup_cycles(scene, res, samples, bounces, threads):
    """Cycles computing what PTIR's estimator computes (see the module notes), opaque film, EXR output."""
    kit.plain_cycles(scene, res, samples, max(1, threads))
    kit.match_estimator(scene, bounces)
    kit.exr_output(scene)


def matched_material(name, base_color, roughness, metallic):
    """Lambert + GGX whose colours match our BRDF's directional albedo (disney_match.py)."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    mat["ptir_base_color"] = list(base_color)
    mat["ptir_roughness"] = float(roughness)
    mat["ptir_metallic"] = float(metallic)
    mat.diffuse_color = (*base_color, 1.0)
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    # x = cos(theta_o) = 1 - Facing (Layer Weight with blend 0.5: Facing = 1 - |N.I|).
    lw = nt.nodes.new("ShaderNodeLayerWeight")
    lw.inputs["Blend"].default_value = 0.5
    one_minus = nt.nodes.new("ShaderNodeMath")
    one_minus.operation = "SUBTRACT"
    one_minus.inputs[0].default_value = 1.0
    nt.links.new(lw.outputs["Facing"], one_minus.inputs[1])
    xyz = nt.nodes.new("ShaderNodeCombineXYZ")
    for k in range(3):
        nt.links.new(one_minus.outputs[0], xyz.inputs[k])
    # Three curves of x: X -> 1 - Sd, Y -> R1/RC, Z -> RS/RC, piecewise linear.
    xs, f_d, f_1, f_s = disney_match.matched_curves(roughness)
    curves = nt.nodes.new("ShaderNodeVectorCurve")
    mapping = curves.mapping
    mapping.use_clip = False
    for ci, ys in enumerate((f_d, f_1, f_s)):
        curve = mapping.curves[ci]
        pts = curve.points
        while len(pts) > 2:
            pts.remove(pts[-1])
        pts[0].location = (float(xs[0]), float(ys[0]))
        pts[1].location = (float(xs[1]), float(ys[1]))
        for x, y in zip(xs[2:], ys[2:]):
            pts.new(float(x), float(y))
        for p in pts:
            p.handle_type = "VECTOR"
    mapping.update()
    curves.inputs["Fac"].default_value = 1.0
    nt.links.new(xyz.outputs[0], curves.inputs["Vector"])
    sep = nt.nodes.new("ShaderNodeSeparateXYZ")
    nt.links.new(curves.outputs[0], sep.inputs[0])
    a = np.asarray(base_color, np.float64)
    f0 = disney_match.DIELECTRIC_F0 * (1.0 - metallic) + metallic * a
    # Diffuse colour = (1-m)(1-F0) a * f_d (per channel constant times a scalar).
    kd = (1.0 - metallic) * (1.0 - f0) * a
    dcol = nt.nodes.new("ShaderNodeVectorMath")
    dcol.operation = "SCALE"
    dcol.inputs[0].default_value = tuple(float(v) for v in kd)
    nt.links.new(sep.outputs[0], dcol.inputs["Scale"])
    # Glossy colour = F0 * f_1 + (1 - F0) * f_s.
    g1 = nt.nodes.new("ShaderNodeVectorMath")
    g1.operation = "SCALE"
    g1.inputs[0].default_value = tuple(float(v) for v in f0)
    nt.links.new(sep.outputs[1], g1.inputs["Scale"])
    gs = nt.nodes.new("ShaderNodeVectorMath")
    gs.operation = "SCALE"
    gs.inputs[0].default_value = tuple(float(1.0 - v) for v in f0)
    nt.links.new(sep.outputs[2], gs.inputs["Scale"])
    gcol = nt.nodes.new("ShaderNodeVectorMath")
    gcol.operation = "ADD"
    nt.links.new(g1.outputs[0], gcol.inputs[0])
    nt.links.new(gs.outputs[0], gcol.inputs[1])
    diffuse = nt.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Roughness"].default_value = 0.0
    nt.links.new(dcol.outputs[0], diffuse.inputs["Color"])
    glossy = nt.nodes.new("ShaderNodeBsdfGlossy")
    glossy.distribution = "GGX"
    glossy.inputs["Roughness"].default_value = max(float(roughness), disney_match.MIN_ROUGHNESS)
    nt.links.new(gcol.outputs[0], glossy.inputs["Color"])
    add = nt.nodes.new("ShaderNodeAddShader")
    nt.links.new(diffuse.outputs[0], add.inputs[0])
    nt.links.new(glossy.outputs[0], add.inputs[1])
    nt.links.new(add.outputs[0], out.inputs["Surface"])
    return mat


def mesh_object(scene, name, verts, faces, material):
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(v) for v in verts], [], [tuple(f) for f in faces])
    me.update()
    for p in me.polygons:
        p.use_smooth = False
    me.materials.append(material)
    ob = bpy.data.objects.new(name, me)
    scene.collection.objects.link(ob)
    ob.cycles.shadow_terminator_geometry_offset = 0.0
    ob.cycles.shadow_terminator_offset = 0.0
    return ob


def quad(scene, name, corners, material):
    return mesh_object(scene, name, corners, [(0, 1, 2, 3)], material)


def box(scene, name, centre, size, angle_z, material):
    sx, sy, sz = (0.5 * s for s in size)
    verts = [(x, y, z) for z in (-sz, sz) for y in (-sy, sy) for x in (-sx, sx)]
    # Outward-facing quads (right-handed winding).
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    ob = mesh_object(scene, name, verts, faces, material)
    ob.location = centre
    ob.rotation_euler = (0.0, 0.0, angle_z)
    return ob


def add_camera(scene, location, target, fov_x):
    return kit.add_camera(scene, location, Vector(target) - Vector(location), fov_x=fov_x, name="camera")


# ---------------------------------------------------------------- scenes

def build_cornell(scene, hole=False):
    white = matched_material("white", (0.75, 0.75, 0.75), 1.0, 0.0)
    red = matched_material("red", (0.63, 0.065, 0.05), 1.0, 0.0)
    green = matched_material("green", (0.14, 0.45, 0.091), 1.0, 0.0)
    # Walls (quads facing into the box): floor, ceiling, back, left (red), right (green).
    quad(scene, "floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], white)
    if hole:
        # The ceiling with an opening the size of the light above it (the light sits in it).
        hx, hy = 0.3, 0.25
        for name, (x0, x1, y0, y1) in (("ceiling_s", (-1, 1, -1, -hy)), ("ceiling_n", (-1, 1, hy, 1)),
                                       ("ceiling_w", (-1, -hx, -hy, hy)), ("ceiling_e", (hx, 1, -hy, hy))):
            quad(scene, name, [(x0, y0, 2), (x0, y1, 2), (x1, y1, 2), (x1, y0, 2)], white)
    else:
        quad(scene, "ceiling", [(-1, -1, 2), (-1, 1, 2), (1, 1, 2), (1, -1, 2)], white)
    quad(scene, "back", [(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], white)
    quad(scene, "left", [(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], red)
    quad(scene, "right", [(1, -1, 0), (1, -1, 2), (1, 1, 2), (1, 1, 0)], green)
    box(scene, "tall_box", (-0.35, 0.3, 0.6), (0.6, 0.6, 1.2), math.radians(20.0), white)
    box(scene, "short_box", (0.4, -0.3, 0.3), (0.6, 0.6, 0.6), math.radians(-20.0), white)
    light = kit.add_light(scene, "AREA", 40.0, location=(0.0, 0.0, 1.98), shape="RECTANGLE", size=0.6, size_y=0.5)
    light.visible_camera = True  # Blender 3.4's default is False; our engine shows lights to camera rays
    add_camera(scene, (0.0, -3.9, 1.0), (0.0, 0.0, 1.0), math.radians(38.0))
    return 3


def build_glossy(scene, metallic, env_path):
    grey = matched_material("plane", (0.5, 0.5, 0.5), 1.0, 0.0)
    colour = (0.8, 0.2, 0.1) if metallic == 0 else (0.9, 0.7, 0.3)
    obj_mat = matched_material("object", colour, 0.3, float(metallic))
    quad(scene, "plane", [(-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)], grey)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=6, radius=0.5, location=(0.0, 0.0, 0.5))
    sphere = bpy.context.active_object
    sphere.name = "object"
    for p in sphere.data.polygons:
        p.use_smooth = False
    sphere.data.materials.append(obj_mat)
    sphere.cycles.shadow_terminator_geometry_offset = 0.0
    add_camera(scene, (0.0, -2.6, 0.95), (0.0, 0.0, 0.42), math.radians(40.0))
    kit.set_environment(scene, env_path, ENV_ROTATION_Z)
    return 2


def render_to_array(scene, path, seed):
    """Renders with Cycles to path (EXR); returns (linear RGB float32 (h, w, 3), row 0 = top; seconds)."""
    secs = kit.render_still(scene, path, seed)
    arr = kit.read_pixels(path)[::-1, :, :3]  # Blender rows are bottom-up
    return np.ascontiguousarray(arr), secs


def main():
    args = parse_args()
    result = {"blender": bpy.app.version_string, "samples": args.samples, "res": args.res, "jobs": {}}
    for job in args.jobs:
        scene = reset_scene()
        if job in ("cornell", "cornell_hole"):
            bounces = build_cornell(scene, hole=job == "cornell_hole")
        elif job in ("glossy_m0", "glossy_m1"):
            if not args.env:
                raise SystemExit("--env is required for %s" % job)
            bounces = build_glossy(scene, 0 if job == "glossy_m0" else 1, args.env)
        else:
            raise SystemExit("unknown job %s" % job)
        setup_cycles(scene, args.res, args.samples, bounces, args.threads)
        scene.cycles.pixel_filter_type, scene.cycles.filter_width = args.pixel_filter, args.filter_width
        job_dir = os.path.join(args.out_dir, job)
        os.makedirs(job_dir, exist_ok=True)
        info = {"bounces": bounces, "cycles_seconds": []}
        for seed in args.seeds:
            arr, secs = render_to_array(scene, os.path.join(job_dir, "cycles_seed%d.exr" % seed), seed)
            np.save(os.path.join(job_dir, "cycles_seed%d.npy" % seed), arr)
            info["cycles_seconds"].append(secs)
        warnings = []
        t0 = time.time()
        info["scene"] = scene_export.export_scene(bpy.context, os.path.join(job_dir, "export"),
                                                  integrator={"spp": args.samples, "bounces": bounces},
                                                  warnings=warnings)
        info["export_seconds"] = time.time() - t0
        # The matched materials reproduce the simplified Disney BRDF: render with that model.
        with open(info["scene"]) as f:
            doc = json.load(f)
        doc["brdf"] = "disney-simplified"
        with open(info["scene"], "w") as f:
            json.dump(doc, f, indent=1)
        info["export_warnings"] = warnings
        result["jobs"][job] = info
    print("PTIR_CYCLES_COMPARE_JSON: " + json.dumps(result))
    sys.stdout.flush()


if __name__ == "__main__":
    kit.run_main(main)
