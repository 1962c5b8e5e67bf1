"""A tiny training dataset for the optimiser tests (numpy + the CLI; no bpy).

make_dataset(folder, cli) writes
    gt.ply                splats of a sphere (icosahedron subdivided twice: 320 flat Gaussians, radius
                          0.6, centred at (0, 0, 0.7)) with the ground-truth material
    input.ply             the same splats without material properties (the engine's defaults:
                          albedo 0.3, roughness 0.6): what the artist imports
    floor.ply             a 4 x 4 m floor at z = 0
    gt_scene.json         gt.ply + the floor (base colour FLOOR_GT) under a white environment
    transforms_train.json 6 cameras on a ring looking at the sphere, 32 x 32 px, images train/r_<i>.png
                          rendered by `ptir render` (RGBA PNG, alpha = coverage)
and returns a dict of the paths and the ground truth.
"""

import json
import math
import os
import subprocess

import numpy as np

from blender_kit import look_at
from ptir_blender.io import mesh_ply, surface_splats

ALBEDO_GT = (0.70, 0.25, 0.10)
ROUGHNESS_GT = 0.5
FLOOR_GT = (0.15, 0.45, 0.20)
SIZE = 32
VIEWS = 6
FOV_X = 0.9


def icosphere(subdiv=2):
    t = (1.0 + 5 ** 0.5) / 2.0
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
         (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
         (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    verts = [np.array(p, np.float64) / np.linalg.norm(p) for p in v]
    for _ in range(subdiv):
        cache, nf = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = verts[a] + verts[b]
                verts.append(m / np.linalg.norm(m))
                cache[key] = len(verts) - 1
            return cache[key]
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    return np.array(verts), np.array(f)


def cameras():
    out = []
    for i in range(VIEWS):
        a = 2 * math.pi * i / VIEWS + 0.3
        eye = (2.6 * math.cos(a), 2.6 * math.sin(a), 1.6 + 0.3 * (i % 2))
        out.append(look_at(eye, (0.0, 0.0, 0.6)))
    return out


def make_dataset(folder, cli):
    os.makedirs(os.path.join(folder, "train"), exist_ok=True)
    v, f = icosphere(2)
    v = v * 0.6 + np.array([0.0, 0.0, 0.7])
    g = surface_splats.triangles_to_gaussians(v, f)
    gt = os.path.join(folder, "gt.ply")
    surface_splats.write_gaussians_ply(gt, g, albedo=ALBEDO_GT, roughness=ROUGHNESS_GT, metallic=0.0)
    inp = os.path.join(folder, "input.ply")
    surface_splats.write_gaussians_ply(inp, g, write_normals=False)
    floor = os.path.join(folder, "floor.ply")
    mesh_ply.write_mesh_ply(floor, [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], [(0, 1, 2), (0, 2, 3)])
    cams = cameras()
    scene = {"gaussians": [{"file": "gt.ply"}],
             "meshes": [{"name": "floor", "file": "floor.ply",
                         "material": {"base_color": list(FLOOR_GT), "roughness": 0.9, "metallic": 0.0}}],
             "environment": {"type": "color", "color": [1.0, 1.0, 1.0], "strength": 1.0},
             "cameras": [{"name": "r_%d" % i, "transform": m.tolist(), "fov_x": FOV_X, "width": SIZE,
                          "height": SIZE} for i, m in enumerate(cams)]}
    scene_json = os.path.join(folder, "gt_scene.json")
    with open(scene_json, "w") as fh:
        json.dump(scene, fh)
    for i in range(VIEWS):
        out = os.path.join(folder, "train", "r_%d.png" % i)
        r = subprocess.run([str(cli), "render", scene_json, "--camera", "r_%d" % i, "-o", out, "--spp", "64",
                            "--bounces", "1", "-q"], capture_output=True, text=True)
        if r.returncode != 0:
            raise RuntimeError("rendering the dataset failed: %s" % r.stderr)
    frames = [{"file_path": "./train/r_%d" % i, "transform_matrix": m.tolist()} for i, m in enumerate(cams)]
    with open(os.path.join(folder, "transforms_train.json"), "w") as fh:
        json.dump({"camera_angle_x": FOV_X, "frames": frames}, fh)
    return {"dir": folder, "gt": gt, "input": inp, "floor": floor, "cameras": cams, "count": len(f)}
