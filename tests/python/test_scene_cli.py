"""Scene files through `ptir render scene.json` and the Python module; replay determinism.

The scene used here has every kind of element: a wall of flat Gaussians, a mesh
floor and back wall, an area light, a point light, a sun and a lat-long
environment, path-traced with 3 bounces.
"""

import json
import math
import subprocess

import numpy as np
import pytest

from blender_kit import look_at
from ptir_testing import write_quad_ply, write_splat_ply


def run(cli, *args, timeout=120):
    return subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True, timeout=timeout)


def write_env(ptir, path, w=32, h=16):
    img = np.zeros((h, w, 3), np.float32)
    img[:, :] = np.linspace(0.2, 1.0, h)[:, None, None] * np.array([0.4, 0.6, 1.0])
    img[3, 5] = (30.0, 28.0, 25.0)
    ptir.write_image(str(path), img)
    return path


@pytest.fixture()
def scene_file(tmp_path, ptir):
    # A 9 x 9 wall of thin Gaussians standing at y = 0 (facing -y, toward the camera).
    g = np.linspace(-0.8, 0.8, 9)
    xz = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    pos = np.column_stack([xz[:, 0], np.zeros(len(xz)), xz[:, 1] + 1.0])
    spacing = g[1] - g[0]
    # Local z (the thin axis) along world y: rotate +90 degrees about x.
    q = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)
    write_splat_ply(tmp_path / "wall.ply", pos, (0.6 * spacing, 0.6 * spacing, 1e-3 * spacing), quat=q,
                    colour=(0.8, 0.3, 0.1))
    write_quad_ply(tmp_path / "floor.ply", 0.0, 4.0)
    write_env(ptir, tmp_path / "sky.exr")
    scene = {
        "gaussians": [{"file": "wall.ply", "transform": [[1, 0, 0, 0.2], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}],
        "meshes": [
            {"name": "floor", "file": "floor.ply", "material": {"base_color": [0.6, 0.6, 0.6], "roughness": 0.8}},
            {"name": "back", "vertices": [[-3, 2, 0], [3, 2, 0], [3, 2, 3], [-3, 2, 3]],
             "triangles": [[0, 1, 2], [0, 2, 3]],
             "material": {"base_color": [0.2, 0.5, 0.3], "roughness": 0.4, "metallic": 0.5}},
        ],
        "lights": [
            {"type": "area", "shape": "disk", "size": 0.8, "power": 60,
             "transform": [[1, 0, 0, 0], [0, 1, 0, -1.0], [0, 0, 1, 2.8], [0, 0, 0, 1]]},
            {"type": "point", "position": [1.5, -1.5, 1.5], "power": 40, "radius": 0.05},
            {"type": "sun", "direction": [-0.3, -0.5, 1.0], "strength": 1.5, "angle": 0.05},
        ],
        "environment": {"type": "latlong", "file": "sky.exr", "strength": 0.8, "rotation_z": 0.3},
        "cameras": [
            {"name": "front", "transform": look_at([0.0, -4.0, 1.2], [0.0, 0.0, 1.0]).tolist(), "fov_x": 0.9,
             "width": 40, "height": 32},
            {"name": "side", "transform": look_at([3.0, -3.0, 1.0], [0.0, 0.0, 1.0]).tolist(), "fov_x": 0.9,
             "width": 24, "height": 24},
        ],
        "integrator": {"spp": 4, "bounces": 3, "seed": 5},
    }
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene, indent=1))
    return path


def read(ptir, path):
    return ptir.read_image(str(path))


def test_render_scene_file_writes_exr_and_png(cli, ptir, scene_file, tmp_path):
    out = tmp_path / "out.exr"
    stats = tmp_path / "stats.json"
    r = run(cli, "render", scene_file, "-o", out, "--stats-json", stats)
    assert r.returncode == 0, r.stderr
    assert "rgb, 4 spp, 3 bounces" in r.stderr
    img = read(ptir, out)
    assert img.shape == (32, 40, 4)
    assert np.all(np.isfinite(img)) and img[..., :3].min() >= 0.0
    assert img[..., :3].mean() > 0.01
    assert img[..., 3].min() >= 0.0 and img[..., 3].max() <= 1.0
    assert img[..., 3].mean() > 0.9  # floor, back wall and splats cover all but the top row (sky)
    s = json.loads(stats.read_text())
    assert s["gaussians"] == 81 and s["triangles"] == 4 and s["lights"] == 3
    assert s["paths"] == 32 * 40 * 4 and s["path_samples"] == 32 * 40 * 4
    # PNG: 8-bit sRGB of the same render.
    png = tmp_path / "out.png"
    r = run(cli, "render", scene_file, "-o", png, "-q")
    assert r.returncode == 0, r.stderr
    import skimage.io
    p = skimage.io.imread(png)
    assert p.dtype == np.uint8 and p.shape == (32, 40, 3)  # RGB: the environment is part of the picture
    lin = np.clip(img[..., :3], 0, 1)
    enc = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    assert np.abs(p[..., :3] / 255.0 - enc).max() < 1.5 / 255


def test_overrides_and_camera_choice(cli, ptir, scene_file, tmp_path):
    out = tmp_path / "side.exr"
    r = run(cli, "render", scene_file, "-o", out, "--camera", "side", "--spp", 2, "--bounces", 1, "-q")
    assert r.returncode == 0, r.stderr
    assert read(ptir, out).shape == (24, 24, 4)
    r = run(cli, "render", scene_file, "-o", out, "--camera", "1", "-q")  # by index
    assert r.returncode == 0, r.stderr
    assert read(ptir, out).shape == (24, 24, 4)
    r = run(cli, "render", scene_file, "-o", out, "--width", 20, "-q")  # resize keeps the aspect ratio
    assert r.returncode == 0, r.stderr
    assert read(ptir, out).shape == (16, 20, 4)
    r = run(cli, "render", scene_file, "-o", out, "--camera", "top")
    assert r.returncode == 1
    assert "no camera named 'top' (cameras: front, side)" in r.stderr


def test_replay_determinism_independent_of_threads(cli, ptir, scene_file, tmp_path):
    """Same seed -> bit-identical EXR with 1 and 2 threads; another seed -> another image."""
    outs = {}
    for threads in (1, 2):
        out = tmp_path / ("t%d.exr" % threads)
        r = run(cli, "render", scene_file, "-o", out, "--seed", 42, "--spp", 8, "--threads", threads, "-q")
        assert r.returncode == 0, r.stderr
        outs[threads] = out
    a, b = read(ptir, outs[1]), read(ptir, outs[2])
    # Every float of every channel bit for bit (the files differ only in their DateTime header).
    assert np.array_equal(a.view(np.uint32), b.view(np.uint32))
    other = tmp_path / "seed43.exr"
    r = run(cli, "render", scene_file, "-o", other, "--seed", 43, "--spp", 8, "-q")
    assert r.returncode == 0, r.stderr
    c = read(ptir, other)
    assert not np.array_equal(a, c)
    # The module renders the same image as the CLI (same seed, same code path), on any thread count: the
    # same RGB; its A is the coverage, the file's 1 (an opaque film in front of the environment, alpha.md).
    scene = ptir.load_scene(str(scene_file))
    m1 = scene.render(seed=42, spp=8, threads=1)
    m2 = scene.render(seed=42, spp=8)
    assert np.array_equal(m1[..., :3].view(np.uint32), a[..., :3].view(np.uint32))
    assert np.array_equal(m2.view(np.uint32), m1.view(np.uint32))
    assert np.all(a[..., 3] == 1.0) and m1[..., 3].min() < 1.0


def test_ablation_switches_change_the_image(cli, ptir, scene_file, tmp_path):
    base = tmp_path / "base.exr"
    assert run(cli, "render", scene_file, "-o", base, "-q").returncode == 0
    ref = read(ptir, base)
    for flags in (["--interaction", "discrete"], ["--no-geometric-criterion"], ["--self-intersection", "fixed"],
                  ["--tau-g", "0.9"]):
        out = tmp_path / "abl.exr"
        r = run(cli, "render", scene_file, "-o", out, "-q", *flags)
        assert r.returncode == 0, (flags, r.stderr)
        img = read(ptir, out)
        assert img.shape == ref.shape
        assert not np.array_equal(img, ref), flags
    r = run(cli, "render", scene_file, "-o", tmp_path / "x.exr", "--self-intersection", "offset")
    assert r.returncode == 1 and "--self-intersection must be 'backface' or 'fixed'" in r.stderr


def test_scene_errors_name_file_and_path(cli, tmp_path):
    bad = tmp_path / "scene.json"
    bad.write_text(json.dumps({"lights": [{"type": "point", "position": [0, 0, 1], "powr": 10}]}))
    r = run(cli, "render", bad, "-o", tmp_path / "x.exr")
    assert r.returncode == 1
    assert "scene.json: lights[0].powr is not a known key" in r.stderr
    bad.write_text(json.dumps({"lights": [{"type": "point", "position": [0, 0, 1], "power": "10"}]}))
    r = run(cli, "render", bad, "-o", tmp_path / "x.exr")
    assert "scene.json: lights[0].power must be a number, got a string" in r.stderr
    r = run(cli, "render", tmp_path / "missing.json", "-o", tmp_path / "x.exr")
    assert r.returncode == 1 and "missing.json: cannot open scene file" in r.stderr
    # Flag-form options do not mix with a scene file.
    bad.write_text("{}")
    r = run(cli, "render", bad, "--env", "sky.exr", "-o", tmp_path / "x.exr")
    assert r.returncode == 1 and "--env belongs to the flag form" in r.stderr


def test_flag_form_rgb_with_environment(cli, ptir, wall_scene, tmp_path):
    """--aov rgb path-traces the flag-form scene under --env; escaping rays see strength x texel."""
    env = np.full((8, 16, 3), 0.5, np.float32)
    ptir.write_image(str(tmp_path / "grey.exr"), env)
    out = tmp_path / "rgb.exr"
    r = run(cli, "render", "--gaussians", wall_scene["ply"], "--cameras", wall_scene["cameras"], "--aov", "rgb",
            "--env", tmp_path / "grey.exr", "--env-strength", 2.0, "--env-rotation", 0.5, "--spp", 4, "--bounces", 1,
            "-o", out, "-q")
    assert r.returncode == 0, r.stderr
    img = read(ptir, out)
    assert img.shape == (32, 32, 4)
    assert img[0, 0, :3] == pytest.approx([1.0, 1.0, 1.0], abs=1e-6)  # the corner sees only the environment
    assert img[0, 0, 3] == 1.0  # an opaque film in front of the environment (docs/alpha.md)
    centre = img[16, 16]
    assert centre[3] == pytest.approx(1.0)
    # The wall (default albedo 0.3) lit by a uniform environment of radiance 1 from the front half
    # (and its own back side): a plausible, non-trivial value below the environment's.
    assert 0.05 < centre[0] < 1.0
    # AOVs of the flag form still work, with the new options rejected where meaningless.
    r = run(cli, "render", "--gaussians", wall_scene["ply"], "--cameras", wall_scene["cameras"], "--aov", "albedo",
            "--bounces", 2, "-o", tmp_path / "a.exr")
    assert r.returncode == 1 and "apply to --aov rgb" in r.stderr


def test_module_scene_api(ptir, scene_file):
    scene = ptir.load_scene(str(scene_file))
    assert scene.camera_names == ["front", "side"]
    assert len(scene.gaussians) == 81 and len(scene.meshes) == 2 and scene.light_count == 3
    assert scene.environment == "latlong"
    assert scene.integrator["spp"] == 4 and scene.integrator["bounces"] == 3 and scene.integrator["seed"] == 5
    img = scene.render()
    assert img.dtype == np.float32 and img.shape == (32, 40, 4)
    assert scene.last_render_stats["paths"] == 32 * 40 * 4
    side = scene.render("side", spp=1, bounces=0)
    assert side.shape == (24, 24, 4)
    assert np.array_equal(scene.render(1, spp=1, bounces=0), side)
    cam = ptir.Camera(np.eye(4, dtype=np.float32), 0.5, 8, 6)
    assert scene.render(cam, spp=1).shape == (6, 8, 4)
    with pytest.raises(ptir.Error, match="no camera named 'nope'"):
        scene.render("nope")
    with pytest.raises(ptir.Error, match="out of range"):
        scene.render(5)
    # The same scene from a dict and from text, with paths relative to base_dir.
    doc = json.loads(scene_file.read_text())
    from_dict = ptir.scene_from_dict(doc, str(scene_file.parent))
    assert np.array_equal(from_dict.render(spp=2), scene.render(spp=2))
    from_text = ptir.scene_from_json_string(json.dumps(doc), str(scene_file.parent), "inline")
    assert from_text.source_path == "inline"
    with pytest.raises(ptir.Error, match=r"inline: integrator.bounce is not a known key"):
        ptir.scene_from_json_string('{"integrator": {"bounce": 1}}', "", "inline")
    # The AOV API works on a loaded scene too.
    aov = scene.render_aov(scene.cameras[0], "albedo")
    assert aov.shape == (32, 40, 4)
