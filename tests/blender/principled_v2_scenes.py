"""Builds the Principled v2 comparison grid in Blender 4.5 / 5.0 (PyPI bpy), renders it with
Cycles and writes the PTIR scene file itself from the values it set.

    <bpy venv>/bin/python tests/blender/principled_v2_scenes.py -- \
        --out-dir DIR --env ENV.exr [--samples 256] [--seeds 1 2] [--res 320] [--jobs ggx multiggx diffuse]

An 8 x 4 grid of Principled v2 spheres (icospheres, 5120 flat faces, radius 0.4) above a
Lambert ground (Diffuse BSDF, roughness 0: the same in every Blender), lit by a lat-long
world (sky gradient + sun patch, the ENV file). Rows: Roughness 0.1 / 0.3 / 0.6 / 0.9.
Columns: see COLUMNS (Specular IOR Level 0.2 / 0.5 / 0.8, IOR 1.3 / 1.5 / 2.0, white and
coloured Specular Tint, Diffuse Roughness 0 / 0.5 / 1, metals and half-metals with and
without an F82 edge tint). Jobs: "ggx" and "multiggx" (the node's Distribution), and "diffuse":
2 x 4 Diffuse BSDF spheres (colours DIFFUSE_COLOURS by row, Roughness DIFFUSE_ROUGHNESS by column).

For each job: Cycles renders with every seed (cycles_seedN.npy, linear RGB, row 0 = top),
a sphere index map (index.npy: 0 = ground/background, k + 1 = sphere k, from a 1-spp
emission render) and scene.json + one binary PLY per sphere and the ground, written
from the same numbers (no add-on exporter involved). Cycles computes what PTIR's path
tracer computes: every bounce limit 2, no glossy filter, no light threshold, caustics
on, a 1-px box filter, no denoising, adaptive sampling or clamping.
Prints one line "PTIR_PRINCIPLED_V2_JSON: {...}".
"""

import argparse
import json
import math
import os
import sys
import time
import traceback

import bpy
import numpy as np
from mathutils import Vector

ROUGHNESS = (0.1, 0.3, 0.6, 0.9)
# (base colour, metallic, IOR, Specular IOR Level, Specular Tint, Diffuse Roughness)
COLUMNS = (((0.8, 0.3, 0.2), 0.0, 1.5, 0.2, (1.0, 1.0, 1.0), 0.0),
           ((0.2, 0.5, 0.8), 0.0, 1.3, 0.5, (1.0, 1.0, 1.0), 0.5),
           ((0.3, 0.7, 0.3), 0.0, 2.0, 0.8, (1.0, 0.6, 0.3), 1.0),
           ((0.7, 0.7, 0.7), 0.0, 1.5, 0.5, (0.4, 0.7, 1.0), 0.0),
           ((0.9, 0.6, 0.3), 1.0, 1.5, 0.5, (1.0, 1.0, 1.0), 0.0),
           ((0.95, 0.64, 0.54), 1.0, 1.5, 0.5, (0.6, 0.8, 1.0), 0.0),
           ((0.6, 0.5, 0.9), 0.5, 1.5, 0.5, (1.0, 1.0, 1.0), 0.0),
           ((0.8, 0.8, 0.3), 0.5, 1.45, 0.5, (1.0, 0.5, 0.5), 0.5))
# The "diffuse" job: Diffuse BSDF nodes (colour by row, Roughness by column).
DIFFUSE_COLOURS = ((0.8, 0.3, 0.2), (0.9, 0.9, 0.85))
DIFFUSE_ROUGHNESS = (0.25, 0.5, 0.75, 1.0)
BOUNCES = 2
GROUND = (0.5, 0.5, 0.5)


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser(prog="principled_v2_scenes.py")
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("--env", required=True)
    ap.add_argument("--samples", type=int, default=256)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--res", type=int, default=320)
    ap.add_argument("--jobs", nargs="+", default=["ggx", "multiggx", "diffuse"])
    return ap.parse_args(argv)


def reset():
    """No objects, meshes, materials, cameras; factory settings otherwise."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def principled(name, distribution, base, roughness, metallic, ior, level, tint, diffuse_roughness):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    node = mat.node_tree.nodes["Principled BSDF"]
    node.distribution = distribution
    node.inputs["Base Color"].default_value = (*base, 1.0)
    node.inputs["Roughness"].default_value = roughness
    node.inputs["Metallic"].default_value = metallic
    node.inputs["IOR"].default_value = ior
    node.inputs["Specular IOR Level"].default_value = level
    node.inputs["Specular Tint"].default_value = (*tint, 1.0)
    node.inputs["Diffuse Roughness"].default_value = diffuse_roughness
    return mat


def single_node_material(name, kind, colour, **inputs):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    node = nt.nodes.new(kind)
    node.inputs["Color"].default_value = (*colour, 1.0)
    for k, v in inputs.items():
        node.inputs[k].default_value = v
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(node.outputs[0], out.inputs["Surface"])
    return mat


def world_environment(scene, path):
    """World = Environment Texture (Closest, equirectangular) of the linear EXR, strength 1."""
    world = bpy.data.worlds.new("World")
    scene.world = world
    world.use_nodes = True
    nt = world.node_tree
    nt.nodes.clear()
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.interpolation = "Closest"
    env.projection = "EQUIRECTANGULAR"
    env.image = bpy.data.images.load(os.path.abspath(path), check_existing=True)
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = 1.0
    out = nt.nodes.new("ShaderNodeOutputWorld")
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])


def add_camera(scene, eye, target, fov_x):
    data = bpy.data.cameras.new("camera")
    data.type = "PERSP"
    data.sensor_fit = "HORIZONTAL"
    data.angle = fov_x
    data.clip_start, data.clip_end = 0.01, 1000.0
    cam = bpy.data.objects.new("camera", data)
    scene.collection.objects.link(cam)
    cam.location = eye
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = (Vector(target) - Vector(eye)).to_track_quat("-Z", "Y")
    scene.camera = cam
    return cam


def cycles_settings(scene, res, samples):
    """Cycles on the CPU computing PTIR's estimator's expectation (see the module docstring)."""
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = samples
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.sample_clamp_direct = cy.sample_clamp_indirect = 0.0
    cy.max_bounces = cy.diffuse_bounces = cy.glossy_bounces = cy.transmission_bounces = BOUNCES
    cy.volume_bounces = 0
    cy.transparent_max_bounces = 8
    cy.blur_glossy = 0.0
    cy.light_sampling_threshold = 0.0
    cy.caustics_reflective = cy.caustics_refractive = True
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    cy.use_animated_seed = False
    scene.render.resolution_x = res
    scene.render.resolution_y = res // 2
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.render.use_compositing = False
    scene.render.use_sequencer = False
    scene.view_settings.view_transform = "Standard"
    st = scene.render.image_settings
    st.file_format = "OPEN_EXR"
    st.color_mode = "RGB"
    st.color_depth = "32"
    st.exr_codec = "ZIP"


def render(scene, path, seed):
    scene.cycles.seed = seed
    scene.render.filepath = path
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    return time.time() - t0


def read_exr(path):
    """Linear float pixels (height, width, 3), row 0 = top."""
    img = bpy.data.images.load(path, check_existing=False)
    try:
        w, h, ch = img.size[0], img.size[1], img.channels
        px = np.empty(w * h * ch, np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    return np.ascontiguousarray(px.reshape(h, w, ch)[::-1, :, :3])


def write_ply(path, obj):
    """The object's triangles in world space as a binary PLY (vertex x,y,z; face vertex_indices)."""
    mesh = obj.data
    mesh.calc_loop_triangles()
    mw = obj.matrix_world
    verts = np.array([tuple(mw @ v.co) for v in mesh.vertices], np.float32)
    tris = np.array([tuple(t.vertices) for t in mesh.loop_triangles], np.int32)
    header = ("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
              "property float z\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n"
              % (len(verts), len(tris)))
    faces = np.zeros(len(tris), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    faces["n"], faces["i"] = 3, tris
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(verts.astype("<f4").tobytes())
        f.write(faces.tobytes())


def sphere_at(row, col, ncol, nrow=4):
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=4, radius=0.4,
                                          location=((col - (ncol - 1) / 2) * 1.0, 0.0, 0.45 + (nrow - 1 - row) * 0.95))
    obj = bpy.context.active_object
    obj.name = "sphere_%d_%d" % (row, col)
    return obj


def build_principled(distribution):
    """The Principled grid: ROUGHNESS rows x COLUMNS."""
    shader = "principled-multiscatter" if distribution == "MULTI_GGX" else "principled"
    spheres, meshes = [], []
    for row, r in enumerate(ROUGHNESS):
        for col, (base, m, ior, level, tint, sigma) in enumerate(COLUMNS):
            obj = sphere_at(row, col, len(COLUMNS))
            obj.data.materials.append(principled(obj.name, distribution, base, r, m, ior, level, tint, sigma))
            spheres.append(obj)
            meshes.append({"name": obj.name, "file": obj.name + ".ply",
                           "material": {"shader": shader, "base_color": list(base), "roughness": r, "metallic": m,
                                        "ior": ior, "specular_ior_level": level, "specular_tint_color": list(tint),
                                        "diffuse_roughness": sigma}})
    return spheres, meshes


def build_diffuse():
    """Diffuse BSDF nodes: DIFFUSE_COLOURS rows x DIFFUSE_ROUGHNESS columns (4.3+: energy-preserving Oren-Nayar)."""
    spheres, meshes = [], []
    for row, colour in enumerate(DIFFUSE_COLOURS):
        for col, sigma in enumerate(DIFFUSE_ROUGHNESS):
            obj = sphere_at(row, col, len(DIFFUSE_ROUGHNESS), len(DIFFUSE_COLOURS))
            obj.data.materials.append(single_node_material(obj.name, "ShaderNodeBsdfDiffuse", colour, Roughness=sigma))
            spheres.append(obj)
            meshes.append({"name": obj.name, "file": obj.name + ".ply",
                           "material": {"shader": "diffuse", "base_color": list(colour), "roughness": sigma}})
    return spheres, meshes


def build(scene, job, job_dir):
    """The spheres, the ground and the camera in Blender; the same as PTIR scene entries."""
    if job == "diffuse":
        spheres, meshes = build_diffuse()
    else:
        spheres, meshes = build_principled("MULTI_GGX" if job == "multiggx" else "GGX")
    bpy.ops.mesh.primitive_plane_add(size=16.0, location=(0.0, 1.5, 0.0))
    ground = bpy.context.active_object
    ground.name = "ground"
    ground.data.materials.append(single_node_material("ground", "ShaderNodeBsdfDiffuse", GROUND, Roughness=0.0))
    meshes.append({"name": "ground", "file": "ground.ply",
                   "material": {"shader": "diffuse", "base_color": list(GROUND), "roughness": 0.0}})
    bpy.context.view_layer.update()
    for obj in spheres + [ground]:
        write_ply(os.path.join(job_dir, obj.name + ".ply"), obj)
    fov_x = math.radians(62.0)
    cam = add_camera(scene, (0.0, -7.6, 2.2), (0.0, 0.0, 1.9), fov_x)
    bpy.context.view_layer.update()
    camera = {"name": "camera", "transform": [list(row) for row in cam.matrix_world], "fov_x": fov_x,
              "width": scene.render.resolution_x, "height": scene.render.resolution_y}
    return spheres, meshes, camera


def index_map(scene, spheres, path):
    """0 = not a sphere, k + 1 = sphere k: a 1-spp render with emission-only materials, black world."""
    scene.world = None
    bpy.data.objects["ground"].hide_render = True
    for k, obj in enumerate(spheres):
        obj.data.materials[0] = single_node_material("index_%d" % k, "ShaderNodeEmission", ((k + 1) / 64.0, 0.0, 0.0))
    scene.cycles.samples = 1
    render(scene, path, 1)
    return np.rint(read_exr(path)[..., 0] * 64.0).astype(np.int32)


def main():
    args = parse_args()
    result = {"blender": bpy.app.version_string, "jobs": {}}
    for job in args.jobs:
        job_dir = os.path.join(args.out_dir, job)
        os.makedirs(job_dir, exist_ok=True)
        scene = reset()
        world_environment(scene, args.env)
        cycles_settings(scene, args.res, args.samples)
        spheres, meshes, camera = build(scene, job, job_dir)
        doc = {"version": 1, "brdf": "principled-v2",
               "comment": "Principled v2 grid, Blender %s, %s" % (bpy.app.version_string, job),
               "meshes": meshes, "cameras": [camera],
               "environment": {"type": "latlong", "file": os.path.abspath(args.env), "strength": 1.0},
               "integrator": {"spp": args.samples, "bounces": BOUNCES, "pixel_filter": "box", "filter_width": 1.0}}
        scene_path = os.path.join(job_dir, "scene.json")
        with open(scene_path, "w") as f:
            json.dump(doc, f, indent=1)
        info = {"scene": scene_path, "cycles_seconds": []}
        for seed in args.seeds:
            exr = os.path.join(job_dir, "cycles_seed%d.exr" % seed)
            info["cycles_seconds"].append(render(scene, exr, seed))
            np.save(os.path.join(job_dir, "cycles_seed%d.npy" % seed), read_exr(exr))
        np.save(os.path.join(job_dir, "index.npy"), index_map(scene, spheres, os.path.join(job_dir, "index.exr")))
        result["jobs"][job] = info
    print("PTIR_PRINCIPLED_V2_JSON: " + json.dumps(result))
    sys.stdout.flush()


if __name__ == "__main__":
    try:
        main()
    except Exception:
        traceback.print_exc()
        sys.exit(1)
