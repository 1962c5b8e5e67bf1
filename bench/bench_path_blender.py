"""Blender side of bench/bench_path.py: builds the heterogeneous benchmark scene,
exports it (mesh-only and with the object as Gaussians) and times Cycles.

    blender -b --factory-startup -noaudio --python-exit-code 1 -P bench/bench_path_blender.py -- \
        --out DIR --env sky.exr [--subdiv 4] [--res 256] [--spp 32] [--bounces 2] [--threads 2] [--repeat 3]
        [--no-cycles]

Scene: the bundled sample's object (scripts/make_sample_splat.py: Suzanne on a box
pedestal; --subdiv 4 gives ~130K surface Gaussians), a floor and two walls (meshes),
one rectangular area light and a lat-long environment (--env). Materials are plain
Principled BSDFs (Blender 3.4's, GGX, specular 0.5): what our default surface model
computes, so that Cycles and our renderer compute the same image (the benchmark also
reports how close they are) and Cycles pays for the shader an artist would use.

Writes DIR/mesh/scene.json (everything as meshes: what Cycles renders) and
DIR/hetero/scene.json (the object as flat surface Gaussians with the same
materials + the mesh walls/floor, light, environment), DIR/cycles.npy, and prints
"PTIR_BENCH_JSON: {...}" with Cycles' timing.
"""

import argparse
import json
import math
import os
import sys
import time

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
for p in (os.path.join(REPO, "scripts"), os.path.join(REPO, "tests", "blender"), os.path.join(REPO, "addon")):
    sys.path.insert(0, p)

import blender_kit as kit  # noqa: E402
import cycles_compare_scenes as ccs  # noqa: E402  (scene helpers and Cycles settings)
import principled_compare_scenes as pcs  # noqa: E402  (a Principled BSDF material)
import make_sample_splat as sample  # noqa: E402  (the sample object)
from ptir_blender.blender import scene_export  # noqa: E402
from ptir_blender.io import scene_file, surface_splats  # noqa: E402

# Linear base colours, roughness, metallic of the object's parts.
MATERIALS = {
    "head": ((0.70, 0.15, 0.03), 0.45, 0.0),
    "eyes": ((0.01, 0.01, 0.02), 0.15, 0.0),
    "pedestal_top": ((0.65, 0.62, 0.52), 0.7, 0.0),
    "pedestal_side": ((0.03, 0.15, 0.27), 0.35, 1.0),
}


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--env", required=True)
    ap.add_argument("--subdiv", type=int, default=4)
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--bounces", type=int, default=2)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3, help="timed Cycles renders after the first")
    ap.add_argument("--no-cycles", action="store_true")
    return ap.parse_args(argv)


def principled(name, base_color, roughness, metallic):
    """Blender's default Principled BSDF (GGX, specular 0.5, no tint) with these inputs."""
    return pcs.principled(name, base_color, roughness, metallic, 0.5, 0.0, "GGX")


def build(args):
    scene = ccs.reset_scene()
    mats = {name: principled(name, *params) for name, params in MATERIALS.items()}
    ped = sample.make_pedestal(2.0, 0.3)
    parts = [ped] + sample.make_suzanne(args.subdiv, 0.3)
    for obj in parts:
        for slot in obj.material_slots:
            slot.material = mats[slot.material.name.split(".")[0]]
    floor_mat = principled("floor", (0.45, 0.45, 0.45), 0.9, 0.0)
    wall_mat = principled("wall", (0.6, 0.55, 0.5), 1.0, 0.0)
    ccs.quad(scene, "floor", [(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)], floor_mat)
    ccs.quad(scene, "wall_back", [(-5, 3, 0), (5, 3, 0), (5, 3, 4), (-5, 3, 4)], wall_mat)
    ccs.quad(scene, "wall_left", [(-3, -5, 0), (-3, 5, 0), (-3, 5, 4), (-3, -5, 4)], wall_mat)
    light = kit.add_light(scene, "AREA", 150.0, location=(1.5, -1.5, 3.2), rotation=(math.radians(25), 0, 0),
                          shape="RECTANGLE", size=1.2, size_y=0.8)
    light.visible_camera = True
    ccs.add_camera(scene, (2.6, -4.2, 2.2), (0.0, 0.0, 0.8), math.radians(40.0))
    kit.set_environment(scene, args.env, 0.0, strength=0.6)
    ccs.setup_cycles(scene, args.res, args.spp, args.bounces, args.threads)
    return scene, parts


def object_gaussians(parts):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    pieces = []
    for obj in parts:
        loops, start, total, mat = kit.world_polygons(obj, depsgraph)
        g = surface_splats.polygons_to_gaussians(loops, start, total)
        names = [s.material.name for s in obj.material_slots]
        g["albedo"] = np.array([MATERIALS[names[i]][0] for i in mat])
        g["roughness"] = np.array([MATERIALS[names[i]][1] for i in mat])
        g["metallic"] = np.array([MATERIALS[names[i]][2] for i in mat])
        pieces.append(g)
    return {k: np.concatenate([p[k] for p in pieces]) for k in pieces[0]}


def main():
    args = parse_args()
    os.makedirs(args.out, exist_ok=True)
    t0 = time.time()
    scene, parts = build(args)
    integ = {"spp": args.spp, "bounces": args.bounces}
    mesh_path = scene_export.export_scene(bpy.context, os.path.join(args.out, "mesh"), integrator=integ)
    # The heterogeneous version: the object's parts as Gaussians.
    g = object_gaussians(parts)
    hetero_dir = os.path.join(args.out, "hetero")
    os.makedirs(hetero_dir, exist_ok=True)
    surface_splats.write_gaussians_ply(os.path.join(hetero_dir, "object_gaussians.ply"), g, albedo=g["albedo"],
                                       roughness=g["roughness"], metallic=g["metallic"])
    doc = json.load(open(mesh_path))
    part_names = {o.name for o in parts}
    doc["meshes"] = [dict(m, file=os.path.join("..", "mesh", m["file"])) for m in doc["meshes"]
                     if m["name"].rsplit("_", 1)[0] not in part_names and m["name"] not in part_names]
    doc["gaussians"] = [{"file": "object_gaussians.ply"}]
    doc["comment"] = "bench_path: the sample object as %d surface Gaussians + mesh floor/walls" % len(g["position"])
    scene_file.write_scene(os.path.join(hetero_dir, "scene.json"), doc)
    tris = sum(len(o.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.polygons) for o in parts)
    result = {"gaussians": int(len(g["position"])), "object_polygons": int(tris), "setup_seconds": time.time() - t0,
              "mesh_scene": mesh_path, "hetero_scene": os.path.join(hetero_dir, "scene.json")}
    if not args.no_cycles:
        # The first render includes kernel/shader setup; then --repeat timed renders (each
        # bpy.ops.render.render as a whole: sync, BVH build, path tracing, EXR written).
        times = []
        for i in range(1 + args.repeat):
            arr, secs = ccs.render_to_array(scene, os.path.join(args.out, "cycles.exr"), seed=1)
            times.append(secs)
        result["cycles_seconds_first"] = times[0]
        result["cycles_seconds"] = times[1:]
        np.save(os.path.join(args.out, "cycles.npy"), arr)
        result["cycles_threads"] = args.threads
    print("PTIR_BENCH_JSON: " + json.dumps(result))
    sys.stdout.flush()


if __name__ == "__main__":
    kit.run_main(main)
