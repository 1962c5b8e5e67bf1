"""Smooth-shaded meshes as an artist makes them, exported by the add-on, with Cycles renders.

Run inside Blender 3.4 or a bpy module (4.1+: the corner_normals export path), headless:

    blender -b --factory-startup -noaudio --python-exit-code 1 -P tests/blender/smooth_mesh_scene.py -- \
        --out-dir DIR [--res 128] [--samples 256] [--bounces 2]

Three objects whose facets Cycles hides: a low-poly UV sphere (16 x 8, smooth shaded), a torus
(24 x 12, smooth shaded) and a cylinder (16 sides) with auto smooth at 30 degrees (3.x; 4.1+: Shade
Smooth by Angle, sharp edges from the angle) (smooth sides,
sharp cap edges: split normals; its caps stay flat), on a flat-shaded floor plane. Uniform
Principled materials, the dataset maker's "studio" environment. Writes
    DIR/cycles.npy          the Cycles (CPU) render, float32 H x W x 3 linear (no denoising, adaptive
                            sampling or clamping, Box 1 px, every bounce limit = --bounces, opaque film)
    DIR/export/scene.json   the scene through the add-on's scene_export (meshes with per-corner normals)
and prints one line "PTIR_SMOOTH_MESH_JSON: {...}".
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
from ptir_blender.blender import scene_export  # noqa: E402


def parse_args():
    return kit.scene_script_args()


def smooth(obj, auto_smooth_deg=None):
    for poly in obj.data.polygons:
        poly.use_smooth = True
    if auto_smooth_deg is None:
        return
    if hasattr(obj.data, "set_sharp_from_angle"):  # Blender 4.1+: Shade Smooth by Angle (sharp edges)
        obj.data.set_sharp_from_angle(angle=math.radians(auto_smooth_deg))
    else:  # Blender 3.x: Object Data > Normals > Auto Smooth
        obj.data.use_auto_smooth = True
        obj.data.auto_smooth_angle = math.radians(auto_smooth_deg)


def build_objects():
    mat = dscene.principled_material
    bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, radius=0.55, location=(-0.75, 0.1, 0.55))
    sphere = bpy.context.active_object
    sphere.data.materials.append(mat("sphere", (0.7, 0.25, 0.2), 0.3))
    smooth(sphere)
    bpy.ops.mesh.primitive_torus_add(major_radius=0.5, minor_radius=0.2, major_segments=24, minor_segments=12,
                                     location=(0.65, -0.1, 0.45), rotation=(math.radians(-55.0), 0.0, 0.0))
    torus = bpy.context.active_object
    torus.data.materials.append(mat("torus", (0.75, 0.6, 0.3), 0.4))
    smooth(torus)
    bpy.ops.mesh.primitive_cylinder_add(vertices=16, radius=0.3, depth=0.7, location=(-0.1, -0.95, 0.35))
    cyl = bpy.context.active_object
    cyl.data.materials.append(mat("cylinder", (0.25, 0.45, 0.75), 0.35))
    smooth(cyl, auto_smooth_deg=30.0)
    bpy.ops.mesh.primitive_plane_add(size=4.0, location=(0.0, 0.0, 0.0))
    floor = bpy.context.active_object
    floor.data.materials.append(mat("floor", (0.5, 0.5, 0.5), 0.6))
    return [sphere, torus, cyl, floor]


def main():
    a = parse_args()
    os.makedirs(a.out_dir, exist_ok=True)
    dscene.clear_scene()
    build_objects()
    scene = bpy.context.scene
    env_path = os.path.join(a.out_dir, "studio.exr")
    exr.write_exr(env_path, envmaps.make_envmap("studio", 128, 64))
    kit.set_environment(scene, env_path)
    cam = dscene.camera_object(scene)
    cam.matrix_world = kit_matrix(kit.look_at(np.array([0.9, -3.6, 2.0]), np.array([0.0, 0.1, 0.35])))
    seconds = dscene.render_reference(scene, a.out_dir, a.res, a.samples, a.bounces, a.threads)
    scene_path = scene_export.export_scene(scene, os.path.join(a.out_dir, "export"),
                                           integrator={"bounces": a.bounces})
    print("PTIR_SMOOTH_MESH_JSON: " + json.dumps({"scene": scene_path, "cycles_seconds": seconds,
                                                   "samples": a.samples}), flush=True)


def kit_matrix(m):
    from mathutils import Matrix
    return Matrix(np.asarray(m).tolist())


main()
