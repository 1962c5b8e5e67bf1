"""Builds the Principled BSDF comparison scene in Blender, renders it with Cycles and exports it.

    blender -b --factory-startup -P tests/blender/principled_compare_scenes.py -- \
        --out-dir DIR --env ENV.exr [--samples 256] [--seeds 1 2] [--res 200]

A 5 x 4 grid of spheres (icospheres, 5120 flat faces, radius 0.4) above a ground
plane, lit by a lat-long world (sky gradient + sun patch, the ENV file). Rows:
roughness 0.1 / 0.3 / 0.6 / 0.9. Columns (base colour, metallic, specular, tint):
  0  dielectric (0.8, 0.3, 0.2)  m 0    s 0.2  t 0
  1  dielectric (0.2, 0.5, 0.8)  m 0    s 0.5  t 0
  2  dielectric (0.3, 0.7, 0.3)  m 0    s 0.8  t 1
  3  metal      (0.9, 0.6, 0.3)  m 1    s 0.5  t 0
  4  half-metal (0.6, 0.5, 0.9)  m 0.5  s 0.5  t 1
The ground is a Diffuse BSDF (grey, roughness 0.5: Oren-Nayar).
Jobs: "ggx" (distribution GGX) and "multiggx" (Multiscatter GGX). For each job:
Cycles renders with every seed (cycles_seedN.npy, linear RGB, row 0 = top), the
sphere index map (index.npy: 0 = background/ground, k + 1 = sphere k, from a
1-spp emission render) and the add-on's export (export/scene.json). Cycles is set
up by blender_kit.match_estimator (box filter 1 px, bounces 2, no glossy filter).
Prints one line "PTIR_PRINCIPLED_COMPARE_JSON: {...}".
"""

import argparse
import json
import math
import os
import sys

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(REPO, "scripts"))

import blender_kit as kit  # noqa: E402  (also puts the add-on on sys.path)
from ptir_blender.blender import scene_export  # noqa: E402

ROUGHNESS = (0.1, 0.3, 0.6, 0.9)
COLUMNS = (((0.8, 0.3, 0.2), 0.0, 0.2, 0.0),
           ((0.2, 0.5, 0.8), 0.0, 0.5, 0.0),
           ((0.3, 0.7, 0.3), 0.0, 0.8, 1.0),
           ((0.9, 0.6, 0.3), 1.0, 0.5, 0.0),
           ((0.6, 0.5, 0.9), 0.5, 0.5, 1.0))
BOUNCES = 2


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser(prog="principled_compare_scenes.py")
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("--env", required=True)
    ap.add_argument("--samples", type=int, default=256)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--res", type=int, default=200)
    ap.add_argument("--jobs", nargs="+", default=["ggx", "multiggx"])
    return ap.parse_args(argv)


def principled(name, base, roughness, metallic, specular, tint, distribution):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    node = mat.node_tree.nodes["Principled BSDF"]
    node.distribution = distribution
    node.inputs["Base Color"].default_value = (*base, 1.0)
    node.inputs["Roughness"].default_value = roughness
    node.inputs["Metallic"].default_value = metallic
    node.inputs["Specular"].default_value = specular
    node.inputs["Specular Tint"].default_value = tint
    return mat


def diffuse(name, colour, roughness):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (*colour, 1.0)
    d.inputs["Roughness"].default_value = roughness
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(d.outputs[0], out.inputs["Surface"])
    return mat


def build(scene, distribution):
    spheres = []
    for row, r in enumerate(ROUGHNESS):
        for col, (base, m, s, t) in enumerate(COLUMNS):
            bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=4, radius=0.4,
                                                  location=((col - 2) * 1.0, 0.0, 0.45 + (3 - row) * 0.95))
            obj = bpy.context.active_object
            obj.name = "sphere_%d_%d" % (row, col)
            obj.data.materials.append(principled("m_%d_%d" % (row, col), base, r, m, s, t, distribution))
            spheres.append(obj)
    bpy.ops.mesh.primitive_plane_add(size=12.0, location=(0.0, 1.5, 0.0))
    ground = bpy.context.active_object
    ground.name = "ground"
    ground.data.materials.append(diffuse("ground", (0.5, 0.5, 0.5), 0.5))
    eye = np.array([0.0, -7.5, 2.2])
    kit.add_camera(scene, eye, np.array([0.0, 0.0, 1.9]) - eye, fov_x=math.radians(48.0))
    return spheres


def index_map(scene, spheres, path):
    """0 = not a sphere, k + 1 = sphere k: a 1-spp render with emission-only materials."""
    saved_world = scene.world
    scene.world = bpy.data.worlds.new("black")
    ground = bpy.data.objects["ground"]
    ground.hide_render = True
    for k, obj in enumerate(spheres):
        mat = bpy.data.materials.new("index_%d" % k)
        mat.use_nodes = True
        nt = mat.node_tree
        nt.nodes.clear()
        em = nt.nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = ((k + 1) / 64.0, 0.0, 0.0, 1.0)
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        nt.links.new(em.outputs[0], out.inputs["Surface"])
        obj.data.materials[0] = mat
    samples = scene.cycles.samples
    scene.cycles.samples = 1
    kit.render_still(scene, path, 1)
    scene.cycles.samples = samples
    arr = kit.read_pixels(path)[::-1, :, 0]
    return np.rint(arr * 64.0).astype(np.int32)


def main():
    args = parse_args()
    result = {"blender": bpy.app.version_string, "jobs": {}}
    for job in args.jobs:
        scene = kit.reset_scene()
        kit.set_environment(scene, args.env, rotation_z=None)
        spheres = build(scene, "MULTI_GGX" if job == "multiggx" else "GGX")
        kit.plain_cycles(scene, args.res, args.samples)
        scene.render.resolution_y = int(args.res * 0.8)
        kit.match_estimator(scene, BOUNCES)
        kit.exr_output(scene)
        job_dir = os.path.join(args.out_dir, job)
        os.makedirs(job_dir, exist_ok=True)
        info = {"cycles_seconds": []}
        for seed in args.seeds:
            exr = os.path.join(job_dir, "cycles_seed%d.exr" % seed)
            info["cycles_seconds"].append(kit.render_still(scene, exr, seed))
            np.save(os.path.join(job_dir, "cycles_seed%d.npy" % seed),
                    np.ascontiguousarray(kit.read_pixels(exr)[::-1, :, :3]))
        warnings = []
        info["scene"] = scene_export.export_scene(bpy.context, os.path.join(job_dir, "export"),
                                                  integrator={"spp": args.samples, "bounces": BOUNCES},
                                                  warnings=warnings)
        info["warnings"] = warnings
        np.save(os.path.join(job_dir, "index.npy"), index_map(scene, spheres, os.path.join(job_dir, "index.exr")))
        result["jobs"][job] = info
    print("PTIR_PRINCIPLED_COMPARE_JSON: " + json.dumps(result))
    sys.stdout.flush()


if __name__ == "__main__":
    kit.run_main(main)
