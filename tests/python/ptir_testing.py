"""Shared pieces of the Python tests (imported as ptir_testing; conftest.py exposes its fixtures):

The build folder is $PTIR_BUILD_DIR (the Makefile exports it), else <repo>/build.
"""

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("PTIR_BUILD_DIR", REPO / "build")).resolve()
CLI = BUILD / "bin" / "ptir"
MODULE_DIR = BUILD / "python"
sys.path.insert(0, str(REPO / "scripts"))  # blender_kit: the scripts' shared helpers (look_at)

SH_C0 = 0.28209479177387814

# Blender in the background, as the tests that make Cycles datasets call it, and
# the mark that skips them where it is not installed.
BLENDER = [os.environ.get("BLENDER", "blender"), "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1"]
needs_blender = pytest.mark.skipif(shutil.which(BLENDER[0]) is None, reason="blender not installed")


def run_checked(cmd, timeout):
    """Runs cmd (paths allowed); fails the test with the command and its output's tail unless it exits 0."""
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, " ".join(map(str, cmd)) + "\n" + r.stdout[-3000:] + r.stderr[-3000:]
    return r


def write_splat_ply(path, position, sigma, quat=None, opacity=0.95, colour=(0.5, 0.5, 0.5), sh_rest=45):
    """Writes a standard INRIA 3DGS PLY (binary, float32) from activated values.

    position (n, 3); sigma (n, 3) standard deviations; quat (n, 4) w,x,y,z
    (identity when None); opacity and colour scalars/rows broadcast to n.
    """
    position = np.atleast_2d(np.asarray(position, np.float64))
    n = len(position)
    sigma = np.broadcast_to(np.asarray(sigma, np.float64), (n, 3))
    quat = np.broadcast_to(np.asarray((1.0, 0.0, 0.0, 0.0) if quat is None else quat, np.float64), (n, 4))
    opacity = np.broadcast_to(np.asarray(opacity, np.float64), (n,))
    colour = np.broadcast_to(np.asarray(colour, np.float64), (n, 3))
    names = (["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"]
             + ["f_rest_%d" % i for i in range(sh_rest)]
             + ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"])
    rec = np.zeros(n, dtype=[(name, "<f4") for name in names])
    for i, c in enumerate("xyz"):
        rec[c] = position[:, i]
    for i in range(3):
        rec["f_dc_%d" % i] = (colour[:, i] - 0.5) / SH_C0
        rec["scale_%d" % i] = np.log(sigma[:, i])
    for i in range(4):
        rec["rot_%d" % i] = quat[:, i]
    rec["opacity"] = np.log(opacity / (1.0 - opacity))
    header = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
    header += "".join("property float %s\n" % name for name in names) + "end_header\n"
    Path(path).write_bytes(header.encode("ascii") + rec.tobytes())
    return Path(path)


def write_quad_ply(path, z, half):
    """An ASCII PLY quad (two triangles) in the plane z = const, facing +z."""
    h = half
    Path(path).write_text(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
        f"{-h} {-h} {z}\n{h} {-h} {z}\n{h} {h} {z}\n{-h} {h} {z}\n3 0 1 2\n3 0 2 3\n")
    return Path(path)


def look_down_minus_z(eye=(0.0, 0.0, 0.0)):
    """Row-major 4x4 camera-to-world: identity rotation (camera looks down -z)."""
    m = np.eye(4, dtype=np.float32)
    m[:3, 3] = eye
    return m


def write_transforms(path, matrices, fov_x=math.radians(40.0), size=(32, 32)):
    frames = [{"file_path": "./test_%03d/rgba" % i, "transform_matrix": np.asarray(m).tolist()}
              for i, m in enumerate(matrices)]
    Path(path).write_text(json.dumps({"camera_angle_x": fov_x, "w": size[0], "h": size[1], "frames": frames}))
    return Path(path)


def fibonacci_sphere(n):
    """n points spread evenly over the unit sphere (the Fibonacci lattice), from the top down."""
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    r = np.sqrt(1 - z * z)
    phi = i * math.pi * (3 - math.sqrt(5))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], 1)


def quat_z_to(n):
    """Unit quaternions (w, x, y, z) rotating +z onto each row of n."""
    q = np.zeros((len(n), 4))
    for k, v in enumerate(n):
        c, d = np.cross([0, 0, 1.0], v), v[2]
        q[k] = (0, 1, 0, 0) if d < -0.999999 else np.array([1 + d, *c]) / np.linalg.norm([1 + d, *c])
    return q


def sphere_scene(ptir, folder, n, sky, cameras):
    """The sphere capture of the optimiser tests, made in `folder`; returns (scene, positions, albedo).

    g.ply: n flat Gaussians tangent to the unit sphere at Fibonacci points, facing out, 0.7 of the
    point spacing wide and 1e-3 of it thick; env.exr: an 8 x 16 lat-long sky whose row r is
    (red - r red_step, green - r green_step, 1) for sky = ((red, red_step), (green, green_step)),
    with a sun texel (8, 7, 5) at row 1, column 4; the cameras of `cameras`, a transforms file in
    `folder` the caller has written; albedo warm on top (0.7, 0.3, 0.2), cool below (0.2, 0.5, 0.7).
    Roughness is the caller's to set.
    """
    folder = Path(folder)
    p = fibonacci_sphere(n)
    spacing = math.sqrt(4 * math.pi / n)
    write_splat_ply(folder / "g.ply", p, (0.7 * spacing, 0.7 * spacing, 1e-3 * spacing), quat=quat_z_to(p))
    (red, red_step), (green, green_step) = sky
    env = np.zeros((8, 16, 3), np.float32)
    for r in range(8):
        env[r] = [red - red_step * r, green - green_step * r, 1.0]
    env[1, 4] = [8, 7, 5]
    ptir.write_image(str(folder / "env.exr"), env)
    scene = ptir.scene_from_dict({"gaussians": [{"file": "g.ply"}], "environment": {"type": "latlong", "file": "env.exr"},
                                  "cameras": [{"transforms": cameras}]}, base_dir=str(folder))
    albedo = np.where(p[:, 2:3] > 0, [[0.7, 0.3, 0.2]], [[0.2, 0.5, 0.7]]).astype(np.float32)
    scene.gaussians.albedo = albedo
    return scene, p, albedo


@pytest.fixture(scope="session")
def ptir():
    """The native module from the build folder."""
    if not any(MODULE_DIR.glob("ptir*.so")):
        pytest.fail(f"no native module in {MODULE_DIR} (run 'make build' or set PTIR_BUILD_DIR)")
    sys.path.insert(0, str(MODULE_DIR))
    import ptir as module
    return module


@pytest.fixture(scope="session")
def cli():
    if not CLI.exists():
        pytest.fail(f"no CLI at {CLI} (run 'make build' or set PTIR_BUILD_DIR)")
    return CLI


@pytest.fixture()
def wall_scene(tmp_path):
    """A flat wall of overlapping thin Gaussians at z = -4 (a 9x9 grid, 1x1 units),
    a floor quad behind it at z = -6, and a camera at the origin looking at it."""
    g = np.linspace(-0.5, 0.5, 9)
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    pos = np.column_stack([xy, np.full(len(xy), -4.0)])
    spacing = g[1] - g[0]
    ply = write_splat_ply(tmp_path / "wall.ply", pos, (0.6 * spacing, 0.6 * spacing, 1e-3 * spacing),
                          colour=(0.8, 0.3, 0.1))
    mesh = write_quad_ply(tmp_path / "back.ply", -6.0, 10.0)
    cams = write_transforms(tmp_path / "transforms_test.json", [look_down_minus_z()])
    return {"ply": ply, "mesh": mesh, "cameras": cams, "dir": tmp_path}
