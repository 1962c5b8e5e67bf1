"""Training-view files for `ptir optimize`, without bpy.

The optimiser reads a NeRF-synthetic style folder: transforms_<split>.json with
camera-to-world matrices (camera looking down -z, y up: Blender's camera
convention) and image paths. This module writes such a file for views given as
(matrix, horizontal FOV, image path) -- the scene's cameras with their images,
or a dataset moved along with its splat object -- and reads one back.
"""

import json
import math
import os

import numpy as np
from ..errors import DatasetError


def read_transforms(path):
    """The parsed transforms JSON (dict) with 'frames'; raises DatasetError naming what is wrong."""
    try:
        with open(path) as f:
            doc = json.load(f)
    except OSError as e:
        raise DatasetError("%s: cannot read (%s)" % (path, e.strerror or e))
    except ValueError as e:
        raise DatasetError("%s: not valid JSON (%s)" % (path, e))
    if not isinstance(doc, dict) or not isinstance(doc.get("frames"), list) or not doc["frames"]:
        raise DatasetError("%s: has no 'frames' list" % path)
    for i, fr in enumerate(doc["frames"]):
        if not isinstance(fr, dict) or "transform_matrix" not in fr or "file_path" not in fr:
            raise DatasetError("%s: frames[%d] needs 'file_path' and 'transform_matrix'" % (path, i))
        m = np.asarray(fr["transform_matrix"], np.float64)
        if m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise DatasetError("%s: frames[%d].transform_matrix is not a finite 4x4 matrix" % (path, i))
    if "camera_angle_x" not in doc and not all("camera_angle_x" in fr for fr in doc["frames"]):
        raise DatasetError("%s: missing number 'camera_angle_x'" % path)
    return doc


def rigid_camera(m):
    """A camera-to-world 4x4 with its rotation columns normalised (scale removed; position kept)."""
    m = np.array(m, np.float64).reshape(4, 4)
    for c in range(3):
        n = np.linalg.norm(m[:3, c])
        if n <= 0:
            raise DatasetError("camera matrix has a zero axis")
        m[:3, c] /= n
    m[3] = (0.0, 0.0, 0.0, 1.0)
    return m


def transform_dataset(src_path, dst_path, world_from_dataset):
    """Writes dst_path: src_path's frames with camera-to-world left-multiplied by world_from_dataset (4x4),
    scale removed from the camera rotations, and image paths made absolute (resolved against the source
    folder), so the views line up with splats that were moved by that matrix. Returns the frame count."""
    doc = read_transforms(src_path)
    base = os.path.dirname(os.path.abspath(src_path))
    w = np.asarray(world_from_dataset, np.float64).reshape(4, 4)
    for fr in doc["frames"]:
        fr["transform_matrix"] = rigid_camera(w @ np.asarray(fr["transform_matrix"], np.float64)).tolist()
        fp = fr["file_path"]
        if not os.path.isabs(fp):
            fr["file_path"] = os.path.normpath(os.path.join(base, fp))
    _write(dst_path, doc)
    return len(doc["frames"])


def write_views(dst_path, views):
    """Writes a transforms file for views: a list of dicts {"matrix": 4x4 camera-to-world, "fov_x": radians,
    "image": path, "name": optional}. Images must exist; returns the frame count."""
    if not views:
        raise DatasetError("no views: give cameras with images")
    frames = []
    for v in views:
        img = os.path.abspath(v["image"])
        if not os.path.isfile(img):
            raise DatasetError("camera '%s': image '%s' not found" % (v.get("name", "?"), img))
        fov = float(v["fov_x"])
        if not (0.0 < fov < math.pi):
            raise DatasetError("camera '%s': horizontal field of view %r is not in (0, pi)" % (v.get("name", "?"), fov))
        frames.append({"file_path": img, "camera_angle_x": fov,
                       "transform_matrix": rigid_camera(v["matrix"]).tolist()})
    doc = {"camera_angle_x": frames[0]["camera_angle_x"], "frames": frames}
    _write(dst_path, doc)
    return len(frames)


def _write(path, doc):
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(doc, f, indent=1)
    os.replace(tmp, path)


def read_mesh_materials(path):
    """OUT/mesh_materials.json of `ptir optimize --optimize-meshes`: {mesh name: {base_colour, roughness,
    metallic}}."""
    try:
        with open(path) as f:
            doc = json.load(f)
    except (OSError, ValueError) as e:
        raise DatasetError("%s: cannot read the recovered mesh materials (%s)" % (path, e))
    out = {}
    for i, m in enumerate(doc.get("meshes", [])):
        try:
            out[str(m["name"])] = {"base_color": [float(x) for x in m["base_colour"]],
                                   "roughness": float(m["roughness"]), "metallic": float(m["metallic"])}
        except (KeyError, TypeError, ValueError):
            raise DatasetError("%s: meshes[%d] needs name, base_colour, roughness, metallic" % (path, i))
    return out
