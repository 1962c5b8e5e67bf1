"""The `ptir render` command line: files other tools can read, and clear failures.

Exit codes: 0 success, 1 an error naming the file (or value) at fault, 2 bad usage.
"""

import re
import subprocess

import numpy as np
import pytest
import skimage.io

from ptir_testing import write_splat_ply


def run(cli, *args):
    return subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True, timeout=60)


def render_args(scene, aov, out, *extra):
    return ["render", "--gaussians", scene["ply"], "--mesh", scene["mesh"], "--cameras", scene["cameras"],
            "--frame", 0, "--aov", aov, "-o", out, "-q", *extra]


def exr_info(path):
    """(width, height, channel names, per-channel max) via OpenImageIO's oiiotool."""
    out = subprocess.run(["oiiotool", "-v", "--info", str(path), "--printstats"], capture_output=True, text=True,
                         check=True).stdout
    size = re.search(r"(\d+)\s*x\s*(\d+),\s*(\d+) channel, (\w+) openexr", out)
    assert size, out
    names = [c.strip() for c in re.search(r"channel list: (.*)", out).group(1).split(",")]
    maxima = [float(v) for v in re.search(r"Stats Max: ([^\(]*)\(", out).group(1).split()]
    return int(size.group(1)), int(size.group(2)), names, dict(zip(names, maxima)), size.group(4)


@pytest.mark.parametrize("aov,channels", [("opacity", ["A"]), ("depth", ["A", "Z"]),
                                          ("normal", ["A", "X", "Y", "Z"]), ("preview", ["A", "B", "G", "R"])])
def test_render_writes_exr(cli, wall_scene, tmp_path, aov, channels):
    out = tmp_path / f"{aov}.exr"
    r = run(cli, *render_args(wall_scene, aov, out))
    assert r.returncode == 0, r.stderr
    w, h, names, maxima, fmt = exr_info(out)
    assert (w, h) == (32, 32)
    assert sorted(names) == channels  # EXR stores channels sorted by name
    assert fmt in ("float", "half")
    assert maxima["A"] == pytest.approx(1.0, abs=0.02)  # wall + mesh cover the view
    if aov == "depth":
        assert 4.0 < maxima["Z"] < 6.8  # wall at 4; mesh at 6, 6.75 along the corner rays


@pytest.mark.parametrize("aov", ["preview", "opacity", "albedo", "roughness"])
def test_render_writes_png(cli, wall_scene, tmp_path, aov):
    out = tmp_path / f"{aov}.png"
    r = run(cli, *render_args(wall_scene, aov, out))
    assert r.returncode == 0, r.stderr
    img = skimage.io.imread(out)
    assert img.dtype == np.uint8
    assert img.shape[:2] == (32, 32)
    assert img.max() > 0


def test_progress_line_names_the_output(cli, wall_scene, tmp_path):
    out = tmp_path / "o.exr"
    args = [a for a in render_args(wall_scene, "opacity", out) if a != "-q"]
    r = run(cli, *args)
    assert r.returncode == 0
    assert "wrote" in r.stderr and "o.exr" in r.stderr and "81 Gaussians" in r.stderr


def expect_error(r, *names):
    assert r.returncode == 1, (r.returncode, r.stderr)
    assert "error" in r.stderr
    for name in names:
        assert name in r.stderr, r.stderr
    assert r.stdout == ""


def test_missing_ply(cli, wall_scene, tmp_path):
    scene = dict(wall_scene, ply=tmp_path / "missing_splats.ply")
    expect_error(run(cli, *render_args(scene, "opacity", tmp_path / "o.exr")), "missing_splats.ply")


def test_truncated_ply(cli, wall_scene, tmp_path):
    good = write_splat_ply(tmp_path / "good.ply", np.zeros((50, 3)), (0.1, 0.1, 0.1)).read_bytes()
    bad = tmp_path / "truncated_splats.ply"
    bad.write_bytes(good[:len(good) - 1000])
    scene = dict(wall_scene, ply=bad)
    expect_error(run(cli, *render_args(scene, "opacity", tmp_path / "o.exr")), "truncated_splats.ply")
    assert not (tmp_path / "o.exr").exists()


def test_bad_json(cli, wall_scene, tmp_path):
    bad = tmp_path / "broken_transforms.json"
    bad.write_text('{"camera_angle_x": 0.7, "frames": [')
    scene = dict(wall_scene, cameras=bad)
    expect_error(run(cli, *render_args(scene, "opacity", tmp_path / "o.exr")), "broken_transforms.json")


def test_unknown_aov(cli, wall_scene, tmp_path):
    expect_error(run(cli, *render_args(wall_scene, "sparkle", tmp_path / "o.exr")), "sparkle")


def test_frame_out_of_range(cli, wall_scene, tmp_path):
    args = render_args(wall_scene, "opacity", tmp_path / "o.exr")
    args[args.index("--frame") + 1] = 5
    expect_error(run(cli, *args), "transforms_test.json", "out of range")


@pytest.mark.parametrize("args", [[], ["render"], ["frobnicate"], ["render", "--gaussians"],
                                  ["render", "-o", "x.exr", "--no-such-option"], ["render", "--spp", "many", "-o", "x.exr"]])
def test_bad_usage_exits_2(cli, tmp_path, args):
    r = run(cli, *args)
    assert r.returncode == 2, (args, r.returncode, r.stderr)
    assert r.stderr.strip()


def test_help_exits_0(cli):
    r = run(cli, "render", "--help")
    assert r.returncode == 0
    assert "--aov" in r.stdout
