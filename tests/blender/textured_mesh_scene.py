"""Image-textured meshes as an artist makes them, exported by the add-on, with Cycles renders.

Run in Blender 3.4 (blender -b ... -P) or a bpy module (bpy_run.py), headless:

    blender -b --factory-startup -noaudio --python-exit-code 1 -P tests/blender/textured_mesh_scene.py -- \
        --out-dir DIR [--res 128] [--samples 256] [--bounces 2]

Image files on disk (PNG, written here from numpy patterns), each through an Image Texture node
into a Principled BSDF (v1 in 3.4, v2 in 4.x), default UVs:
  - a smooth UV sphere (32 x 16): Base Color a checker (sRGB, Linear), Roughness stripes (Non-Color),
    a bump pattern through a Normal Map node (tangent space, strength 1);
  - a flat-shaded cube: Base Color a checker with Closest interpolation, Metallic a map (Non-Color),
    the same normal map at strength 0.6 (flat faces: the face normal carries the map);
  - a floor plane: a larger checker on Base Color through a UV Map node.
The dataset maker's "studio" environment. Writes
    DIR/cycles.npy          the Cycles (CPU) render, float32 H x W x 3 linear (no denoising, adaptive
                            sampling or clamping, Box 1 px, every bounce limit = --bounces, opaque film)
    DIR/export/scene.json   the scene through the add-on's scene_export (UVs, tangents, texture entries)
and prints one line "PTIR_TEXTURED_MESH_JSON: {...}" with the export's warnings and those of two
node setups the engine cannot render (a ColorRamp between an image and Roughness; a Bump node on
Normal), which must be reported, not dropped.
"""

import json
import math
import os
import sys

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(REPO, "scripts"))
sys.path.insert(0, os.path.join(REPO, "addon"))

import blender_kit as kit  # noqa: E402
from dataset import envmaps, exr, scene as dscene  # noqa: E402
from ptir_blender.blender import compat, material_export, scene_export  # noqa: E402


def parse_args():
    return kit.scene_script_args()


# ---------------------------------------------------------------- images (rows bottom-up, as Blender's)

def checker(n, squares, a, b):
    i = (np.arange(n) * squares // n)
    mask = (i[:, None] + i[None, :]) % 2 == 0
    return np.where(mask[..., None], np.asarray(a, np.float32), np.asarray(b, np.float32))


def stripes(n, count, lo, hi):
    v = np.where((np.arange(n) * count // n) % 2 == 0, lo, hi).astype(np.float32)
    return np.repeat(np.broadcast_to(v[None, :], (n, n))[..., None], 3, axis=2)


def bump_normals(n, freq, amp):
    """A tangent-space normal map of the height amp * sin(2 pi freq u) sin(2 pi freq v), encoded n / 2 + 1 / 2."""
    u = (np.arange(n) + 0.5) / n
    U, V = np.meshgrid(u, u)  # V: rows (v), U: columns (u)
    k = 2 * math.pi * freq
    dhdu = amp * k * np.cos(k * U) * np.sin(k * V)
    dhdv = amp * k * np.sin(k * U) * np.cos(k * V)
    nrm = np.stack([-dhdu, -dhdv, np.ones_like(U)], axis=-1)
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    return (0.5 * nrm + 0.5).astype(np.float32)


def image_file(name, rgb, folder, colorspace):
    """Writes rgb (h, w, 3) in [0, 1] as an 8-bit PNG and loads it as an artist's image file would be."""
    h, w, _ = rgb.shape
    img = bpy.data.images.new(name, w, h, alpha=False)
    px = np.ones((h, w, 4), np.float32)
    px[..., :3] = rgb
    img.pixels.foreach_set(px.ravel())
    path = os.path.join(folder, name + ".png")
    img.filepath_raw = path
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)
    img = bpy.data.images.load(path, check_existing=False)
    img.colorspace_settings.name = colorspace
    return img


# ---------------------------------------------------------------- materials

def principled(name):
    mat = bpy.data.materials.new(name)
    nt = compat.ensure_nodes(mat)
    p = nt.nodes["Principled BSDF"]
    p.distribution = "GGX"
    for socket, value in dscene.PLAIN_INPUTS[compat.principled_model()].items():
        if p.inputs.get(socket) is not None:
            p.inputs[socket].default_value = value
    return mat, nt, p


def tex_node(nt, image, interpolation="Linear"):
    t = nt.nodes.new("ShaderNodeTexImage")
    t.image = image
    t.interpolation = interpolation
    return t


def normal_mapped(nt, p, image, strength):
    nm = nt.nodes.new("ShaderNodeNormalMap")
    nm.space = "TANGENT"
    nm.inputs["Strength"].default_value = strength
    nt.links.new(tex_node(nt, image).outputs["Color"], nm.inputs["Color"])
    nt.links.new(nm.outputs["Normal"], p.inputs["Normal"])


def build(folder):
    albedo = image_file("sphere_albedo", checker(128, 8, (0.8, 0.25, 0.1), (0.9, 0.85, 0.7)), folder, "sRGB")
    rough = image_file("sphere_rough", stripes(128, 6, 0.15, 0.7), folder, "Non-Color")
    bumps = image_file("bumps", bump_normals(128, 4, 0.04), folder, "Non-Color")
    cube_albedo = image_file("cube_albedo", checker(32, 4, (0.1, 0.35, 0.8), (0.85, 0.85, 0.85)), folder, "sRGB")
    metal = image_file("cube_metal", stripes(64, 4, 0.0, 1.0), folder, "Non-Color")
    floor_albedo = image_file("floor_albedo", checker(64, 8, (0.3, 0.3, 0.3), (0.7, 0.7, 0.7)), folder, "sRGB")

    mat, nt, p = principled("sphere")
    nt.links.new(tex_node(nt, albedo).outputs["Color"], p.inputs["Base Color"])
    nt.links.new(tex_node(nt, rough).outputs["Color"], p.inputs["Roughness"])
    normal_mapped(nt, p, bumps, 1.0)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=0.55, location=(-0.6, 0.1, 0.55))
    sphere = bpy.context.active_object
    sphere.data.materials.append(mat)
    for poly in sphere.data.polygons:
        poly.use_smooth = True

    mat, nt, p = principled("cube")
    p.inputs["Roughness"].default_value = 0.35
    nt.links.new(tex_node(nt, cube_albedo, "Closest").outputs["Color"], p.inputs["Base Color"])
    nt.links.new(tex_node(nt, metal).outputs["Color"], p.inputs["Metallic"])
    normal_mapped(nt, p, bumps, 0.6)
    bpy.ops.mesh.primitive_cube_add(size=0.7, location=(0.6, -0.2, 0.35), rotation=(0.0, 0.0, math.radians(30.0)))
    cube = bpy.context.active_object
    cube.data.materials.append(mat)

    mat, nt, p = principled("floor")
    p.inputs["Roughness"].default_value = 0.6
    t = tex_node(nt, floor_albedo)
    uv = nt.nodes.new("ShaderNodeUVMap")
    nt.links.new(uv.outputs["UV"], t.inputs["Vector"])
    nt.links.new(t.outputs["Color"], p.inputs["Base Color"])
    bpy.ops.mesh.primitive_plane_add(size=4.0, location=(0.0, 0.0, 0.0))
    floor = bpy.context.active_object
    floor.data.materials.append(mat)
    uv.uv_map = floor.data.uv_layers[0].name


def unsupported_warnings(folder):
    """The warnings of node setups the engine cannot render (materials not in the scene)."""
    img = bpy.data.images.get("sphere_rough.png") or next(i for i in bpy.data.images if i.name.startswith("sphere_rough"))
    mat, nt, p = principled("ramp")
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.name = "Roughness Ramp"
    nt.links.new(tex_node(nt, img).outputs["Color"], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], p.inputs["Roughness"])
    bump = nt.nodes.new("ShaderNodeBump")
    bump.name = "Height Bump"
    nt.links.new(bump.outputs["Normal"], p.inputs["Normal"])
    warnings = []
    params = material_export.material_params(mat, warnings)
    return warnings, params


def main():
    a = parse_args()
    os.makedirs(a.out_dir, exist_ok=True)
    dscene.clear_scene()
    images = os.path.join(a.out_dir, "images")
    os.makedirs(images, exist_ok=True)
    build(images)
    scene = bpy.context.scene
    env_path = os.path.join(a.out_dir, "studio.exr")
    exr.write_exr(env_path, envmaps.make_envmap("studio", 128, 64))
    kit.set_environment(scene, env_path)
    cam = dscene.camera_object(scene)
    from mathutils import Matrix
    cam.matrix_world = Matrix(np.asarray(kit.look_at(np.array([0.4, -2.9, 1.6]), np.array([0.0, 0.0, 0.35]))).tolist())
    seconds = dscene.render_reference(scene, a.out_dir, a.res, a.samples, a.bounces, a.threads)
    warnings = []
    scene_path = scene_export.export_scene(scene, os.path.join(a.out_dir, "export"),
                                           integrator={"bounces": a.bounces}, warnings=warnings)
    unsupported, params = unsupported_warnings(images)
    print("PTIR_TEXTURED_MESH_JSON: " + json.dumps({
        "scene": scene_path, "cycles_seconds": seconds, "samples": a.samples, "warnings": warnings,
        "unsupported_warnings": unsupported, "unsupported_params": params,
        "blender": bpy.app.version_string}), flush=True)


main()
