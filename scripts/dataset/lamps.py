"""The known-lamps room of the dataset maker (`make_dataset.py --room lamps`, docs/inversion.md "Known
lamps"): the object stands on a floor in front of a wall, lit by two coloured area lights and nothing
else (a black world). The floor and the wall are meshes with known plain materials; with the lamps they
are written as the scene file the inversion is given (DIR/scene/scene.json, by the add-on's exporter).

The targets show the object alone: the floor and the wall are holdouts (Cycles' Object > Visibility >
Holdout), so a camera ray that meets them writes alpha 0, while every other ray (shadow, bounce) sees
them as the surfaces they are. The images are then what the dataset format expects (the object on a
transparent film, alpha = its coverage), the ground-truth passes hold the object only, and the inversion,
which renders the room from the scene file, compares the object's pixels (its mask: the target's alpha).

The cameras stay on the wall's open side: azimuths in ROOM_AZIMUTHS, the dataset's elevations.
"""

import math

import bpy
import numpy as np

from . import scene as dscene

ROOM_COLLECTION = "PTIR_Room"
WALL_Y = 2.0  # the wall's plane, facing -y (the object fits the radius-1.25 sphere about the origin)
ROOM_AZIMUTHS = (-160.0, -20.0)  # degrees: the cameras' azimuth range (y < 0, in front of the wall)
# name -> (linear base colour, roughness): plain Principled materials (metallic 0)
SURFACES = {"floor": ((0.42, 0.36, 0.30), 0.9), "wall": ((0.55, 0.57, 0.60), 0.8)}
# name -> (location, shape, size, power W, colour): area lights aimed at the object's middle
LAMPS = {"key": ((-2.2, -2.6, 3.0), "SQUARE", 1.0, 260.0, (1.0, 0.82, 0.62)),
         "fill": ((2.8, -1.2, 1.4), "DISK", 1.4, 140.0, (0.62, 0.80, 1.0))}


def _surface_material(name):
    """The Principled material of dscene.principled_material without its ground-truth AOV nodes: the
    room is not the object, and its pixels stay out of albedo.png and roughness.png."""
    colour, rough = SURFACES[name]
    mat = dscene.principled_material("room_" + name, colour, rough)
    for node in list(mat.node_tree.nodes):
        if node.label == dscene.GT_LABEL:
            mat.node_tree.nodes.remove(node)
    return mat


def _quad(name, corners, coll):
    """A one-quad mesh object (corners counter-clockwise seen from the side it faces)."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(c) for c in corners], [], [(0, 1, 2, 3)])
    mesh.update()
    mesh.materials.append(_surface_material(name))
    obj = bpy.data.objects.new(name, mesh)
    coll.objects.link(obj)
    obj.is_holdout = True  # camera rays: alpha 0; every other ray: the surface
    obj.cycles.shadow_terminator_geometry_offset = 0.0
    obj.cycles.shadow_terminator_offset = 0.0
    return obj


def _aim(obj, target):
    from mathutils import Vector
    d = Vector(target) - obj.location
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = d.to_track_quat("-Z", "Y")  # an area light emits along its local -z


def build_lamps_room(objs):
    """The floor (under the object's lowest point), the wall and the two lamps of LAMPS; returns
    (the room's objects, its description for dataset.json)."""
    coll = dscene._collection(ROOM_COLLECTION)
    pts = dscene.world_points(objs)
    z0 = float(pts[:, 2].min()) - 0.002  # just under the object's base (no coincident faces)
    top = z0 + 5.0
    floor = _quad("floor", [(-6.0, -6.0, z0), (6.0, -6.0, z0), (6.0, WALL_Y, z0), (-6.0, WALL_Y, z0)], coll)
    wall = _quad("wall", [(-6.0, WALL_Y, z0), (6.0, WALL_Y, z0), (6.0, WALL_Y, top), (-6.0, WALL_Y, top)], coll)
    centre = pts.mean(0)
    lamps = []
    for name, (loc, shape, size, power, colour) in LAMPS.items():
        data = bpy.data.lights.new(name, "AREA")
        data.energy = power
        data.color = colour
        data.shape = shape
        data.size = size
        obj = bpy.data.objects.new(name, data)
        coll.objects.link(obj)
        obj.location = loc
        _aim(obj, centre)
        obj.visible_camera = False  # the engine's default; the lamps stay out of the pictures
        lamps.append(obj)
    bpy.context.view_layer.update()
    record = {"floor_z": round(z0, 6), "wall_y": WALL_Y, "azimuths": list(ROOM_AZIMUTHS),
              "surfaces": {k: {"base_color": list(c), "roughness": r} for k, (c, r) in SURFACES.items()},
              "lamps": {k: {"location": list(l), "shape": s, "size": sz, "power_w": p, "color": list(c)}
                        for k, (l, s, sz, p, c) in LAMPS.items()},
              "targets": "the object alone: floor and wall are holdouts (alpha 0), lit and occluding as usual"}
    return [floor, wall] + lamps, record


def _eye(distance, el, az):
    return distance * np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def room_poses(n, distance, split, look_at):
    """The dataset's camera layout (make_dataset.train_poses / test_poses: elevations 5..65 degrees
    for training, a 15/35 degree ring for testing) with the azimuths squeezed into ROOM_AZIMUTHS."""
    a0, a1 = (math.radians(v) for v in ROOM_AZIMUTHS)
    out = []
    for i in range(n):
        if split == "train":
            s0, s1 = math.sin(math.radians(5.0)), math.sin(math.radians(65.0))
            el = math.asin(s0 + (s1 - s0) * (i + 0.5) / n)
            frac = (0.6180339887 * i + 0.1) % 1.0
        else:
            el = math.radians(15.0 if i % 2 == 0 else 35.0)
            frac = (i + 0.5) / n
        out.append(look_at(_eye(distance, el, a0 + (a1 - a0) * frac)))
    return out


def export_room_scene(context, objects, out_dir):
    """The room (floor, wall, lamps) as the inversion's scene file out_dir/scene.json, written by the
    add-on's exporter (Blender's light units converted as it converts them); the world is black and
    not written. Returns the file's path."""
    from ptir_blender.blender import scene_export
    import json
    path = scene_export.export_scene(context, out_dir, objects=objects, include_cameras=False)
    with open(path) as f:
        doc = json.load(f)
    doc.pop("environment", None)
    doc["comment"] = "the known-lamps room of make_dataset.py --room lamps: floor, wall, two area lights"
    with open(path, "w") as f:
        json.dump(doc, f, indent=1)
    return path
