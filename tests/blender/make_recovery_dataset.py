"""Cycles-rendered training views of objects with known materials, and their Gaussians.

Run inside Blender (3.4, or bpy 4.5 / 5.0 through tests/blender/blenders.py), headless:

    blender -b --factory-startup -noaudio --python-exit-code 1 \
        -P tests/blender/make_recovery_dataset.py -- --out DIR [--res 80] [--views 14] [--samples 64]

Blender 3.x renders Principled v1, 4.0+ v2; transforms_train.json records which ("ptir_brdf").

Scene: an icosphere and a cube (subdivided into a 16x16 grid per face) floating
above nothing, lit only by a synthetic HDR environment (a blue sky gradient, a
brown ground, and a small bright sun that gives the glossy part visible
highlights). Each object has ONE uniform Principled BSDF (GGX, metallic 0,
specular 0.5 -> F0 = 0.04, no sheen/clearcoat/subsurface): the ground truth of
the recovery test (tests/blender/test_optimize_recovery.py).

Writes into DIR:
    transforms_train.json        NeRF-synthetic cameras (camera_angle_x, c2w with -z forward)
    train_XXX/rgba.png           Cycles renders: RGBA PNG, 8-bit sRGB (Standard view
                                 transform), straight alpha = coverage (film transparent)
    gaussians.ply                one flat Gaussian per face of both objects (INRIA layout,
                                 nx,ny,nz = 0: normals come from the shortest axis)
    truth.json                   per-part albedo/roughness and the Gaussian index ranges
    env.hdr                      the environment (Radiance RGBE), for reference

Render settings chosen so that Cycles computes what the PTIR path tracer models:
box pixel filter of width 1 (our camera samples are uniform in the pixel),
environment texture with Closest interpolation (our lookup is nearest-texel),
no glossy filter, no clamping, no denoiser.

The faces -> Gaussians conversion is the add-on's surface-splat builder
(addon/ptir_blender/io/surface_splats.py, written as scripts/make_sample_splat.py
writes the bundled sample): each Gaussian lies in its face, spans it (sigma = 0.6
x the face extent) and is 1000x thinner along the normal.
"""

import argparse
import json
import math
import os
import sys

import bpy
import numpy as np
from mathutils import Matrix

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(REPO, "scripts"))
import blender_kit as kit  # noqa: E402  (also puts the add-on on sys.path)
import make_sample_splat as splat  # noqa: E402  (its trainer-style PLY writer)
from dataset.scene import PLAIN_INPUTS  # noqa: E402  (dielectric F0 0.04, nothing else, per model)
from ptir_blender.blender import compat  # noqa: E402
from ptir_blender.io import surface_splats  # noqa: E402

ENV_W, ENV_H = 64, 32
FOV_X = 0.75
TARGET = (0.0, 0.0, 0.45)

# Ground truth: linear base colour and roughness per part.
PARTS = {
    "sphere": {"albedo": (0.70, 0.30, 0.12), "roughness": 0.25},
    "cube": {"albedo": (0.15, 0.40, 0.60), "roughness": 0.65},
}


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="make_recovery_dataset.py")
    p.add_argument("--out", required=True)
    p.add_argument("--res", type=int, default=80)
    p.add_argument("--views", type=int, default=14)
    p.add_argument("--samples", type=int, default=64)
    p.add_argument("--material", choices=("principled", "matched"), default="principled")
    return p.parse_args(argv)


# ---------------------------------------------------------------- environment

def env_texel(col, row):
    """Linear RGB of texel (col, row); row 0 = top of the file = +z."""
    t = (row + 0.5) / ENV_H  # theta / pi
    if t < 0.5:  # sky: brighter toward the zenith
        k = 0.7 + 0.6 * (1.0 - 2.0 * t)
        rgb = [0.55 * k, 0.70 * k, 1.00 * k]
    else:  # ground
        rgb = [0.32, 0.27, 0.22]
    # A small sun, 2 x 2 texels around azimuth u = 0.3, elevation ~ 40 degrees.
    if col in (19, 20) and row in (5, 6):
        rgb = [30.0, 27.0, 22.0]
    return rgb


# ---------------------------------------------------------------- objects

def principled(name, albedo, roughness):
    mat = bpy.data.materials.new(name)
    nt = compat.ensure_nodes(mat)
    nt.nodes.clear()
    b = nt.nodes.new("ShaderNodeBsdfPrincipled")
    b.distribution = "GGX"
    b.inputs["Base Color"].default_value = (*albedo, 1.0)
    b.inputs["Roughness"].default_value = roughness
    b.inputs["Metallic"].default_value = 0.0
    for socket, value in PLAIN_INPUTS[compat.principled_model()].items():  # v1 on 3.x, v2 on 4.0+
        if b.inputs.get(socket) is not None:  # (Diffuse Roughness: 4.3+)
            b.inputs[socket].default_value = value
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(b.outputs["BSDF"], out.inputs["Surface"])
    mat.diffuse_color = (*albedo, 1.0)
    return mat


def matched(name, albedo, roughness):
    """Lambert diffuse + GGX glossy mixed by dielectric Fresnel (IOR 1.5, F0 = 0.04) at n.v:
    PTIR's simplified Disney BRDF up to second-order terms (Fresnel at n.v instead of
    h.v, Smith instead of Schlick-GGX masking), without Principled's Burley diffuse."""
    mat = bpy.data.materials.new(name)
    nt = compat.ensure_nodes(mat)
    nt.nodes.clear()
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (*albedo, 1.0)
    d.inputs["Roughness"].default_value = 0.0
    g = nt.nodes.new("ShaderNodeBsdfGlossy")
    g.distribution = "GGX"
    g.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    g.inputs["Roughness"].default_value = roughness
    f = nt.nodes.new("ShaderNodeFresnel")
    f.inputs["IOR"].default_value = 1.5
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(f.outputs["Fac"], mix.inputs["Fac"])
    nt.links.new(d.outputs["BSDF"], mix.inputs[1])
    nt.links.new(g.outputs["BSDF"], mix.inputs[2])
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(mix.outputs["Shader"], out.inputs["Surface"])
    mat.diffuse_color = (*albedo, 1.0)
    return mat


MATERIAL = principled


def make_objects():
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob, do_unlink=True)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=4, radius=0.55, location=(-0.62, -0.05, 0.55))
    sphere = bpy.context.active_object
    sphere.name = "sphere"
    bpy.ops.object.shade_smooth()
    sphere.data.materials.append(MATERIAL("sphere", **PARTS["sphere"]))

    bpy.ops.mesh.primitive_cube_add(size=0.9, location=(0.62, 0.1, 0.45), rotation=(0.0, 0.0, math.radians(25.0)))
    cube = bpy.context.active_object
    cube.name = "cube"
    mod = cube.modifiers.new("grid", "SUBSURF")
    mod.subdivision_type = "SIMPLE"
    mod.levels = mod.render_levels = 4
    cube.data.materials.append(MATERIAL("cube", **PARTS["cube"]))
    return [sphere, cube]


# ---------------------------------------------------------------- cameras and rendering

def camera_positions(views):
    out = []
    ring = max(1, views - views // 3)
    for i in range(views):
        if i < ring:
            az, el, r = 2 * math.pi * i / ring, math.radians(22.0), 3.4
        else:
            j = i - ring
            az, el, r = 2 * math.pi * (j + 0.5) / (views - ring), math.radians(58.0), 3.2
        out.append((TARGET[0] + r * math.cos(el) * math.cos(az), TARGET[1] + r * math.cos(el) * math.sin(az),
                    TARGET[2] + r * math.sin(el)))
    return out


def setup_render(scene, res, samples):
    kit.plain_cycles(scene, res, samples, transparent=True)
    cy = scene.cycles
    cy.seed = 1
    cy.max_bounces = 4
    cy.diffuse_bounces = 4
    cy.glossy_bounces = 4
    cy.transparent_max_bounces = 8
    cy.blur_glossy = 0.0
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    scene.display_settings.display_device = "sRGB"
    s = scene.render.image_settings
    s.file_format = "PNG"
    s.color_mode = "RGBA"
    s.color_depth = "8"
    s.compression = 15


def main():
    global MATERIAL
    args = parse_args()
    MATERIAL = principled if args.material == "principled" else matched
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    scene = bpy.context.scene
    hdr = os.path.join(out, "env.hdr")
    kit.write_rgbe_texels(hdr, ENV_W, ENV_H, env_texel)
    kit.set_environment(scene, hdr, sampling=None, linear=False)
    objects = make_objects()
    setup_render(scene, args.res, args.samples)

    cam_data = bpy.data.cameras.new("cam")
    cam_data.type = "PERSP"
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.angle = FOV_X
    cam_data.clip_start = 0.01
    cam = bpy.data.objects.new("cam", cam_data)
    scene.collection.objects.link(cam)
    scene.camera = cam

    frames = []
    for i, eye in enumerate(camera_positions(args.views)):
        m = kit.look_at(eye, TARGET)
        cam.matrix_world = Matrix(m.tolist())
        bpy.context.view_layer.update()
        name = "train_%03d" % i
        scene.render.filepath = os.path.join(out, name, "rgba.png")
        bpy.ops.render.render(write_still=True)
        frames.append({"file_path": "./%s/rgba" % name,
                       "transform_matrix": [list(map(float, row)) for row in np.array(cam.matrix_world)]})
    with open(os.path.join(out, "transforms_train.json"), "w") as f:
        json.dump({"camera_angle_x": FOV_X, "w": args.res, "h": args.res,
                   "ptir_brdf": "principled-v1" if bpy.app.version < (4, 0, 0) else "principled-v2",
                   "frames": frames}, f, indent=1)

    # Faces -> flat Gaussians, part by part.
    depsgraph = bpy.context.evaluated_depsgraph_get()
    pieces, ranges, start = [], {}, 0
    for ob in objects:
        loops, st, total, _ = kit.world_polygons(ob, depsgraph)
        g = surface_splats.polygons_to_gaussians(loops, st, total)
        g["colour"] = np.tile(np.array(PARTS[ob.name]["albedo"]) ** (1 / 2.2), (len(st), 1))  # preview colour
        pieces.append(g)
        ranges[ob.name] = [start, start + len(st)]
        start += len(st)
    g = {key: np.concatenate([p[key] for p in pieces]) for key in pieces[0]}
    splat.write_gaussians_ply(os.path.join(out, "gaussians.ply"), g)
    truth = {name: dict(PARTS[name], gaussians=ranges[name]) for name in PARTS}
    with open(os.path.join(out, "truth.json"), "w") as f:
        json.dump({"parts": truth, "views": args.views, "res": args.res, "samples": args.samples,
                   "material": args.material}, f, indent=1)
    # The pixel filter of the renders, so `ptir optimize` draws its samples from the same one.
    with open(os.path.join(out, "dataset.json"), "w") as f:
        json.dump({"format": "ptir-dataset/1", "cycles": {"pixel_filter": {"type": "box", "width": 1.0}}}, f, indent=1)
    print("make_recovery_dataset: %d Gaussians, %d views %dx%d -> %s" % (start, args.views, args.res, args.res, out))


if __name__ == "__main__":
    kit.run_main(main, "make_recovery_dataset")
