"""Builds the bundled sample: a procedural object turned into a 3DGS splat file.

Run inside Blender (3.4+):
    blender -b --factory-startup -noaudio -P scripts/make_sample_splat.py -- \
        --out DIR [--subdiv N] [--views N] [--res R]

Scene: Suzanne (head and eyes in distinct colours) resting on a box pedestal,
standing on a floor plane. The object's SURFACE becomes flat Gaussians, one per
face (the add-on's surface-splat builder, addon/ptir_blender/io/surface_splats.py),
exactly as a 3DGS trainer would store them (INRIA layout: log scales,
w,x,y,z quaternion, logit opacity, degree-3 SH with f_rest zero, nx,ny,nz = 0).
Each Gaussian lies in its face's plane (local z = face normal), spans the face in
plane so that neighbours overlap into an opaque shell, and is very thin along the
normal, so the engine must recover normals from the shortest axis.

Writes into DIR:
    gaussians.ply         the splats (binary little-endian)
    floor.ply             the floor as a triangle mesh (for splats + mesh scenes)
    transforms_test.json  NeRF-synthetic cameras on a ring around the object

--subdiv is Suzanne's Catmull-Clark level: 3 (default) gives ~35K Gaussians in a
few seconds, 4 gives ~130K (the benchmark size).
"""

import argparse
import json
import math
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_kit as kit  # noqa: E402  (also puts the add-on on sys.path)
from ptir_blender.io import surface_splats  # noqa: E402

SH_REST = 45                 # f_rest count of a degree-3 trainer file (15 coefficients x 3)
OPACITY = 0.95
SPREAD = 0.6                 # in-plane sigma / face extent: neighbours overlap to O > 0.8 at seams
THIN = 1e-3                  # normal-axis sigma / in-plane sigma (a flat disc, as trainers converge to)
FOV_X = 0.6911112            # NeRF-synthetic's camera_angle_x

# Display colours (sRGB-ish, as a trainer's SH DC term would store them).
COLOURS = {
    "head": (0.85, 0.42, 0.16),
    "eyes": (0.08, 0.10, 0.16),
    "pedestal_top": (0.82, 0.80, 0.74),
    "pedestal_side": (0.18, 0.42, 0.55),
}


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="make_sample_splat.py", description=__doc__.split("\n")[0])
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--subdiv", type=int, default=3, help="Suzanne subdivision level (3: ~35K, 4: ~130K Gaussians)")
    p.add_argument("--views", type=int, default=8, help="number of ring cameras")
    p.add_argument("--res", type=int, default=400, help="image width and height of the cameras")
    return p.parse_args(argv)


def material(name):
    mat = bpy.data.materials.new(name)
    mat.diffuse_color = (*COLOURS[name], 1.0)
    return mat


# ---------------------------------------------------------------- scene building

def clear_scene():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)


def make_pedestal(size, height):
    """Open-bottomed box with near-square faces about `size / 24` wide."""
    # The bottom rests on the floor and is never seen (open_bottom). Uniform cuts give square
    # faces on top; the sides' strips stay anisotropic, which exercises elongated Gaussians.
    return kit.add_pedestal(size, height, 0.5 * height, material("pedestal_top"), material("pedestal_side"), 5,
                            open_bottom=True)


def make_suzanne(level, rest_z):
    """Suzanne facing -y, sitting on z = rest_z; head and eyes as separate objects."""
    bpy.ops.mesh.primitive_monkey_add(size=1.2, location=(0.0, 0.0, 0.0))
    head = bpy.context.active_object
    head.rotation_euler = (math.radians(-10.0), 0.0, 0.0)  # tilt the chin onto the pedestal
    bpy.ops.object.transform_apply(rotation=True)
    lowest = min(v.co.z for v in head.data.vertices)
    head.location.z = rest_z - lowest - 0.02  # sink slightly: no gap under the chin
    # The eyes are loose parts of the mesh: split them off to colour them.
    return kit.separate_suzanne(material, level)


# ---------------------------------------------------------------- faces -> Gaussians

def object_gaussians(obj, depsgraph):
    """One flat Gaussian per face (the add-on's surface-splat builder), coloured by the face's material."""
    loops, start, total, mat = kit.world_polygons(obj, depsgraph)
    g = surface_splats.polygons_to_gaussians(loops, start, total, spread=SPREAD, thin=THIN)
    palette = np.array([m.diffuse_color[:3] for m in obj.data.materials])
    g["colour"] = palette[mat]
    return g


# ---------------------------------------------------------------- files

def write_gaussians_ply(path, g):
    """INRIA 3DGS layout, binary little-endian float32, written in one block: no normals (the engine
    takes each Gaussian's shortest axis) and no material, as a trainer writes it."""
    surface_splats.write_gaussians_ply(path, g, opacity=OPACITY, write_normals=False, sh_rest=SH_REST,
                                       display_colour=g["colour"])


def write_floor_ply(path, half_size):
    """A square floor at z = 0, two triangles facing +z (ASCII PLY)."""
    h = half_size
    verts = [(-h, -h, 0.0), (h, -h, 0.0), (h, h, 0.0), (-h, h, 0.0)]
    faces = [(0, 1, 2), (0, 2, 3)]
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\ncomment PTIR sample floor\n")
        f.write("element vertex %d\nproperty float x\nproperty float y\nproperty float z\n" % len(verts))
        f.write("element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(faces))
        for v in verts:
            f.write("%g %g %g\n" % v)
        for tri in faces:
            f.write("3 %d %d %d\n" % tri)


def write_transforms(path, views, res, target, radius, height):
    frames = []
    for i in range(views):
        # Frame 0 looks at Suzanne's face (she faces -y).
        phi = -0.5 * math.pi + 2.0 * math.pi * i / views
        eye = (radius * math.cos(phi), radius * math.sin(phi), height)
        frames.append({"file_path": "./test_%03d/rgba" % i,
                       "transform_matrix": kit.look_at(eye, target).round(6).tolist()})
    with open(path, "w") as f:
        json.dump({"camera_angle_x": FOV_X, "w": res, "h": res, "frames": frames}, f, indent=1)


def main():
    args = parse_args()
    os.makedirs(args.out, exist_ok=True)
    clear_scene()
    pedestal_height = 0.3
    parts = [make_pedestal(2.0, pedestal_height)] + make_suzanne(args.subdiv, pedestal_height)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    pieces = [object_gaussians(o, depsgraph) for o in parts]
    g = {key: np.concatenate([p[key] for p in pieces]) for key in pieces[0]}
    write_gaussians_ply(os.path.join(args.out, "gaussians.ply"), g)
    write_floor_ply(os.path.join(args.out, "floor.ply"), 5.0)
    write_transforms(os.path.join(args.out, "transforms_test.json"), args.views, args.res,
                     target=(0.0, 0.0, 0.75), radius=4.5, height=2.2)
    print("make_sample_splat: %d Gaussians, %d views (%dx%d) -> %s"
          % (len(g["position"]), args.views, args.res, args.res, os.path.abspath(args.out)))


if __name__ == "__main__":
    kit.run_main(main, "make_sample_splat")
