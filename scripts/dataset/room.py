"""A set's views photographed the way a capture is (make_dataset.py --capture-room; issue 51's
ground truth): the object standing on a floor before a backdrop (two walls meeting in a corner),
all of it lit by the set's environment, rendered by Cycles on an opaque film, and written as a
COLMAP text model with 8-bit sRGB JPEG photos that carry EXIF exposure, a few of them taken at
other exposures.

    DIR/capture/room/sparse/0/{cameras,images,points3D}.txt   one PINHOLE camera (the set's), every
                                                            photo's pose, points on the object's
                                                            splats and on the floor
    DIR/capture/room/images/NAME.jpg                         the photos (quality 90, EXIF ExposureTime,
                                                            FNumber, ISO: OpenImageIO's oiiotool)
    DIR/capture/room/exposures.json                          each photo's true relative exposure
    DIR/capture/room/true_masks/NAME.png                     the object's coverage of each photo (from the
                                                            set's transparent render of the same view): for
                                                            scoring, and for standing in for the user's trainer
    DIR/capture/room/dataset.json                            the set's record (surface model, filter)
    DIR/capture/room/true_room.json                          the floor and walls as a scene file (meshes with
                                                            their true materials: docs/scene_format.md), for
                                                            `ptir optimize --scene`: a perfect proxy

The photos are the set's training views plus, at every 8th position, some of its test views
(capture.holdout_plan, as scripts/nerf_to_colmap.py): `--holdout 8` trains on exactly the set's
training views and holds out views whose ground truth the set has. No masks: finding the object is the capture
stage's job. The floor and the walls are not in the set's gaussians.ply: that is the user's
cleaned object splat.
"""

import json
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np

from . import capture, layouts, png

# Floor: a square this wide under the object; the walls stand on it at +x and +y, this far from
# the centre (outside every camera: the maker's cameras are 4 from the origin), this high.
FLOOR_SIZE, WALL_DISTANCE, WALL_HEIGHT = 16.0, 5.5, 6.0
FLOOR = ((0.55, 0.52, 0.47), 0.6)   # linear base colour, roughness: warm light-grey paper
WALL = ((0.38, 0.40, 0.44), 0.9)    # a cool grey, matte

# The camera's exposure per photo position (the rest 1): two photos at half, two at double.
EXPOSURES = {2: 0.5, 5: 2.0, 10: 0.5, 13: 2.0}
# EXIF of an exposure of 1: t = 1/60 s at f/4, ISO 200 (only t changes).
BASE_EXIF = (1.0 / 60.0, 4.0, 200)
JPEG_QUALITY = 90


def _plane(name, mat, size, location, rotation):
    import bpy  # (here: the rest of this file is plain numpy and imports outside Blender)
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=location, rotation=rotation)
    obj = bpy.context.active_object
    obj.name = name
    obj.scale = size
    obj.data.materials.append(mat)
    obj.cycles.shadow_terminator_geometry_offset = 0.0
    obj.cycles.shadow_terminator_offset = 0.0
    return obj


def build_room(objs):
    """The floor at the object's lowest point and two walls behind it: (the objects, the floor's
    height, its half width)."""
    from . import scene as dscene  # (Blender's side, as _plane)
    z0 = float(dscene.world_points(objs)[:, 2].min())
    floor_mat = dscene.principled_material("room_floor", *FLOOR)
    wall_mat = dscene.principled_material("room_wall", *WALL)
    h = 0.5 * FLOOR_SIZE
    zc = z0 + 0.5 * WALL_HEIGHT
    return [
        _plane("room_floor", floor_mat, (FLOOR_SIZE, FLOOR_SIZE, 1.0), (0.0, 0.0, z0), (0.0, 0.0, 0.0)),
        _plane("room_wall_y", wall_mat, (FLOOR_SIZE, WALL_HEIGHT, 1.0), (0.0, WALL_DISTANCE, zc), (math.pi / 2, 0.0, 0.0)),
        _plane("room_wall_x", wall_mat, (WALL_HEIGHT, FLOOR_SIZE, 1.0), (WALL_DISTANCE, 0.0, zc), (0.0, math.pi / 2, 0.0)),
    ], z0, h


def write_jpeg(path, rgb_linear, exposure, oiiotool="oiiotool"):
    """The photo (linear radiance x exposure, clipped) as an 8-bit sRGB JPEG with its EXIF."""
    tmp = Path(str(path) + ".png")
    png.write_png(tmp, png.to_8bit(png.srgb_encode(np.clip(rgb_linear * exposure, 0.0, 1.0))))
    t, n, iso = BASE_EXIF
    cmd = [oiiotool, str(tmp), "--attrib:type=float", "ExposureTime", repr(t * exposure),
           "--attrib:type=float", "FNumber", repr(n), "--attrib:type=int", "Exif:PhotographicSensitivity", str(iso),
           "--compression", "jpeg:%d" % JPEG_QUALITY, "-o", str(path)]
    try:
        subprocess.run(cmd, check=True, capture_output=True, text=True)
    except FileNotFoundError:
        raise RuntimeError("--capture-room writes its JPEGs with OpenImageIO's oiiotool, which is not installed")
    except subprocess.CalledProcessError as e:
        raise RuntimeError("oiiotool could not write %s: %s" % (path, e.stderr.strip()))
    tmp.unlink()


def sparse_points(splat_positions, floor_z, floor_half, seed=0, n_object=2000, n_floor=1000):
    """COLMAP points: a sample of the object's splat centres and of the floor (grey)."""
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(splat_positions), size=min(n_object, len(splat_positions)), replace=False)
    obj = np.asarray(splat_positions)[pick]
    fl = np.column_stack([rng.uniform(-floor_half, floor_half, (n_floor, 2)), np.full(n_floor, floor_z)])
    pts = np.concatenate([obj, fl])
    rgb = [(128, 128, 128)] * len(pts)
    return [(i + 1, p, c, 0.5, []) for i, (p, c) in enumerate(zip(pts, rgb))]


def quad(corner, u, v):
    """(vertices, triangles) of the parallelogram corner, corner + u, corner + u + v, corner + v."""
    c, u, v = (np.asarray(x, np.float64) for x in (corner, u, v))
    return [list(map(float, p)) for p in (c, c + u, c + u + v, c + v)], [[0, 1, 2], [0, 2, 3]]


def room_scene(floor_z, brdf):
    """The floor and walls build_room makes, as a scene file's meshes (docs/scene_format.md)."""
    h, d, z1 = 0.5 * FLOOR_SIZE, WALL_DISTANCE, floor_z + WALL_HEIGHT
    parts = [("room_floor", FLOOR, quad((-h, -h, floor_z), (2 * h, 0, 0), (0, 2 * h, 0))),
             ("room_wall_y", WALL, quad((-h, d, floor_z), (2 * h, 0, 0), (0, 0, z1 - floor_z))),
             ("room_wall_x", WALL, quad((d, -h, floor_z), (0, 2 * h, 0), (0, 0, z1 - floor_z)))]
    return {"version": 1, "brdf": brdf,
            "comment": "the capture's floor and walls with their true materials (scripts/dataset/room.py)",
            "meshes": [{"name": name, "vertices": vs, "triangles": ts,
                        "material": {"base_color": list(mat[0]), "roughness": mat[1], "metallic": 0.0}}
                       for name, mat, (vs, ts) in parts]}


def write_capture(out, photos, intrinsics, res, points, record, floor_z):
    """photos: [(name, c2w, linear rgb, the object's coverage)] in plan order. Returns the folder."""
    root = Path(out)
    shutil.rmtree(root, ignore_errors=True)
    (root / "images").mkdir(parents=True)
    (root / "true_masks").mkdir(parents=True)
    fx, fy, cx, cy = intrinsics
    imgs, truth = [], {}
    for i, (name, c2w, rgb, mask) in enumerate(photos):
        e = EXPOSURES.get(i, 1.0)
        write_jpeg(root / "images" / (name + ".jpg"), rgb, e)
        png.write_png(root / "true_masks" / (name + ".png"), png.to_8bit(mask))
        truth[name] = e
        R, t = capture.w2c_from_opengl(c2w)
        imgs.append((i + 1, layouts.quat_from_rotation(R), t, 1, name + ".jpg", np.zeros((0, 2)), np.zeros(0, np.int64)))
    layouts.write_colmap_txt(root / "sparse" / "0", {1: ("PINHOLE", res, res, [fx, fy, cx, cy])}, imgs, points)
    (root / "exposures.json").write_text(json.dumps(
        {"relative_exposure": truth, "exif_base": {"ExposureTime": BASE_EXIF[0], "FNumber": BASE_EXIF[1],
                                                   "ISO": BASE_EXIF[2]},
         "room": {"floor_z": floor_z, "floor": {"base_color": FLOOR[0], "roughness": FLOOR[1], "size": FLOOR_SIZE},
                  "walls": {"base_color": WALL[0], "roughness": WALL[1], "distance": WALL_DISTANCE,
                            "height": WALL_HEIGHT}}}, indent=1) + "\n")
    (root / "dataset.json").write_text(json.dumps(record, indent=1) + "\n")
    (root / "true_room.json").write_text(json.dumps(room_scene(floor_z, record["ptir_brdf"]), indent=1) + "\n")
    return root
