"""The cameras of any dataset folder the engine reads (NeRF, COLMAP, 3DGS output,
nerfstudio), without bpy: `ptir cameras` parses the folder with the engine's own
readers (no second parser here) and writes one NeRF-style file whose frames carry
the pinhole intrinsics (fl_x, fl_y, cx, cy) and the image the optimiser reads
(for a distorted lens, the undistorted photo the engine caches next to the data).
"""

import json
import os

import numpy as np

from ..errors import DatasetError, JobError
from . import cli


def is_nerf_folder(folder, split):
    return os.path.isfile(os.path.join(folder, "transforms_%s.json" % split))


def export_cameras(cli_exe, dataset_dir, out_json, split="all", timeout=600):
    """Runs `ptir cameras` and returns the parsed file: {"layout", "w", "h", "frames": [...]}."""
    if not dataset_dir or not os.path.isdir(dataset_dir):
        raise DatasetError("dataset folder '%s' does not exist" % dataset_dir)
    job = cli.ChildJob([cli_exe, "cameras", "--dataset", dataset_dir, "--split", split, "-o", out_json, "--force"])
    rc = job.wait(timeout=timeout)
    if rc is None:
        job.cancel(grace=1.0)
        raise JobError("reading the cameras of '%s' took longer than %d s" % (dataset_dir, timeout))
    if rc != 0:
        raise DatasetError(job.error_message())
    return read_cameras(out_json)


def read_cameras(path):
    try:
        with open(path) as f:
            doc = json.load(f)
    except (OSError, ValueError) as e:
        raise DatasetError("%s: cannot read the cameras (%s)" % (path, e))
    frames = doc.get("frames") if isinstance(doc, dict) else None
    if not frames:
        raise DatasetError("%s: no cameras" % path)
    return doc


def blender_camera(frame, width, height, sensor_width=36.0):
    """Blender camera settings reproducing a pinhole frame: sensor fitted to the larger image side,
    focal length in mm and lens shift (in units of that side; +y up in Blender, down in pixels)."""
    fx, cx, cy = float(frame["fl_x"]), float(frame["cx"]), float(frame["cy"])
    fy = float(frame.get("fl_y", fx))
    side = float(max(width, height))
    return {
        "sensor_fit": "HORIZONTAL" if width >= height else "VERTICAL",
        "sensor_width": sensor_width, "sensor_height": sensor_width,
        "lens": fx * sensor_width / side,
        "shift_x": (0.5 * width - cx) / side,
        "shift_y": (cy - 0.5 * height) / side,
        "pixel_aspect_y_over_x": fx / fy,
        "matrix": np.asarray(frame["transform_matrix"], np.float64).reshape(4, 4),
    }
