"""Nothing lost: what a user trying bad inputs on the real CLI met, each refused
with a message that names the file and the way out.

- outputs over inputs (optimize, eval, relight, render) are refused unless --force;
- temps a killed run left in an output folder are removed at start-up;
- render -o other than .exr/.png is refused before anything is rendered;
- an image too large for memory is refused with the estimate before allocating;
- a truncated image is an error naming it (JPEG/TIFF used to read "fine").
"""

import json
import shutil
import subprocess

import numpy as np
import pytest

from conftest import look_down_minus_z, write_splat_ply, write_transforms
from test_optimize_cli import dataset, optimize  # noqa: F401  (the module's dataset fixture)

DEAD_PID = 2147483646  # above any Linux pid_max: no such process


def run(cli, *args, timeout=300):
    return subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True, timeout=timeout)


def stale_temp(folder, stem="checkpoint", ext=".bin"):
    """A temp of our naming (io/atomic_file.h) left by a process that no longer exists."""
    folder.mkdir(parents=True, exist_ok=True)
    p = folder / f".{stem}.ptir-tmp-{DEAD_PID}{ext}"
    p.write_bytes(b"half a checkpoint")
    return p


@pytest.fixture()
def wall(tmp_path, ptir):
    """A wall of Gaussians, a camera file and a small environment map."""
    g = np.linspace(-0.5, 0.5, 9)
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    pos = np.column_stack([xy, np.full(len(xy), -4.0)])
    ply = write_splat_ply(tmp_path / "wall.ply", pos, (0.07, 0.07, 1e-4), colour=(0.8, 0.3, 0.1))
    cams = write_transforms(tmp_path / "transforms_test.json", [look_down_minus_z()])
    env = tmp_path / "sky.exr"
    ptir.write_image(str(env), np.full((8, 16, 3), 0.5, np.float32))
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps({
        "gaussians": [{"file": "wall.ply"}], "environment": {"type": "latlong", "file": "sky.exr"},
        "cameras": [{"name": "front", "transform": look_down_minus_z().tolist(), "fov_x": 0.7,
                     "width": 24, "height": 16}],
        "integrator": {"spp": 1, "bounces": 1}}))
    return {"ply": ply, "cameras": cams, "env": env, "scene": scene, "dir": tmp_path}


def flag_render(wall, out, *extra):
    return ["render", "--gaussians", wall["ply"], "--cameras", wall["cameras"], "-o", out, "-q", *extra]


# --- outputs over inputs ---------------------------------------------------------------------------

def test_optimize_refuses_out_equal_to_the_dataset(cli, dataset, tmp_path):
    ds = tmp_path / "ds"
    shutil.copytree(dataset, ds)
    shutil.move(ds / "g.ply", ds / "gaussians.ply")  # the trainer's file, named as optimize names its output
    before, env_before = (ds / "gaussians.ply").read_bytes(), (ds / "env.exr").read_bytes()
    cmd = ["optimize", "--dataset", ds, "--gaussians", ds / "gaussians.ply", "--out", ds, "--iters", 1, "--spp", 1,
           "--threads", 1, "--env-size", "16x8", "-q"]
    r = run(cli, *cmd)
    assert r.returncode == 1
    assert str(ds) in r.stderr and "--force" in r.stderr and "input" in r.stderr
    assert (ds / "gaussians.ply").read_bytes() == before
    assert (ds / "env.exr").read_bytes() == env_before  # the dataset's own map, named as optimize names its output
    assert not (ds / "log.csv").exists()
    # A result folder inside the dataset folder is fine (nothing is written among the inputs) ...
    assert run(cli, *cmd[:6], ds / "result", *cmd[7:]).returncode == 0
    assert (ds / "result" / "gaussians.ply").is_file()
    # ... and --force writes where it is told.
    r = run(cli, *cmd, "--force")
    assert r.returncode == 0, r.stderr
    assert (ds / "gaussians.ply").read_bytes() != before


def test_optimize_removes_a_killed_runs_temps(cli, dataset, tmp_path):
    out = tmp_path / "out"
    dead = stale_temp(out)
    live = out / ".checkpoint.ptir-tmp-1.bin"  # pid 1 exists: its writer may still be at work
    live.write_bytes(b"x")
    r = optimize(cli, dataset, out, "--iters", 1)
    assert not dead.exists() and live.exists()
    assert "removed 1 unfinished temporary file" in r.stderr


def test_relight_and_eval_refuse_writing_among_inputs(cli, dataset, tmp_path):
    result = tmp_path / "result"
    optimize(cli, dataset, result, "--iters", 1)
    before = (result / "gaussians.ply").read_bytes()
    r = run(cli, "relight", "--result", result, "--cameras", dataset / "transforms_train.json", "--frame", 0,
            "--env", dataset / "env.exr", "--spp", 1, "-o", result, "-q")
    assert r.returncode == 1 and "--force" in r.stderr and str(result) in r.stderr
    assert (result / "gaussians.ply").read_bytes() == before
    # an image too large is refused before the asset is loaded
    r = run(cli, "relight", "--result", result, "--cameras", dataset / "transforms_train.json", "--frame", 0,
            "--env", dataset / "env.exr", "--width", 100000, "--height", 100000, "-o", tmp_path / "big", "-q")
    assert r.returncode == 1 and "100000x100000" in r.stderr and "GiB" in r.stderr
    # relight into its own folder works, and clears a killed run's temps there first
    relit = tmp_path / "relit"
    dead = stale_temp(relit, "train_000", ".exr")
    r = run(cli, "relight", "--result", result, "--cameras", dataset / "transforms_train.json", "--frame", 0,
            "--env", dataset / "env.exr", "--spp", 1, "--bounces", 0, "-o", relit, "-q")
    assert r.returncode == 0, r.stderr
    assert not dead.exists() and (relit / "train_000.exr").is_file()
    # eval writes RESULT/eval: an input kept there would be written among
    (result / "eval").mkdir()
    shutil.copy(dataset / "env.exr", result / "eval" / "sky.exr")
    r = run(cli, "eval", "--dataset", dataset, "--result", result, "--split", "train", "--relight",
            f"sky={result / 'eval' / 'sky.exr'}", "-q")
    assert r.returncode == 1 and "sky.exr" in r.stderr and "--force" in r.stderr
    assert not (result / "eval" / "metrics.json").exists()


def test_render_refuses_output_over_an_input(cli, ptir, wall, tmp_path):
    env_before = wall["env"].read_bytes()
    r = run(cli, *flag_render(wall, wall["env"], "--env", wall["env"], "--aov", "rgb"))
    assert r.returncode == 1 and str(wall["env"]) in r.stderr and "--force" in r.stderr
    # scene form: the map the scene names, and the scene file itself as --stats-json
    r = run(cli, "render", wall["scene"], "-o", wall["env"], "-q")
    assert r.returncode == 1 and "is an input file" in r.stderr
    r = run(cli, "render", wall["scene"], "-o", tmp_path / "ok.exr", "--stats-json", wall["scene"], "-q")
    assert r.returncode == 1 and "scene.json" in r.stderr
    assert wall["env"].read_bytes() == env_before
    assert not (tmp_path / "ok.exr").exists()  # refused before rendering
    r = run(cli, "render", wall["scene"], "-o", wall["env"], "-q", "--force")
    assert r.returncode == 0, r.stderr
    assert ptir.read_image(str(wall["env"])).shape == (16, 24, 4)


def test_render_stats_json_is_whole_and_temps_are_cleared(cli, wall, tmp_path):
    dead = stale_temp(tmp_path, "out", ".png")
    stats = tmp_path / "stats.json"
    r = run(cli, *flag_render(wall, tmp_path / "out.png", "--stats-json", stats))
    assert r.returncode == 0, r.stderr
    assert json.loads(stats.read_text())["width"] == 32
    assert not dead.exists()
    assert not [p for p in tmp_path.iterdir() if ".ptir-tmp-" in p.name]


# --- output formats ----------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["x.tiff", "x.tif", "x.jpg", "x.hdr", "x"])
def test_render_refuses_formats_other_than_exr_and_png(cli, wall, tmp_path, name):
    r = run(cli, *flag_render(wall, tmp_path / name))
    assert r.returncode == 1
    assert ".exr" in r.stderr and ".png" in r.stderr and name in r.stderr
    assert not (tmp_path / name).exists()


def test_render_accepts_upper_case_png(cli, wall, tmp_path):
    r = run(cli, *flag_render(wall, tmp_path / "x.PNG"))
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "x.PNG").read_bytes()[1:4] == b"PNG"


# --- image sizes -------------------------------------------------------------------------------------

C2W = " ".join(str(v) for v in np.eye(4).ravel())


@pytest.mark.parametrize("size", [(100000, 100000), (65536, 65536), (30000, 30000)])
def test_render_refuses_images_too_large_before_allocating(cli, wall, tmp_path, size):
    w, h = size
    for args in (["render", "--gaussians", wall["ply"], "--c2w", C2W, "--fov-x", 0.7],  # flag form
                 ["render", wall["scene"]]):                                            # scene form
        r = run(cli, *args, "--width", w, "--height", h, "-o", tmp_path / "big.exr", "-q",
                "--max-memory", 8, timeout=30)
        assert r.returncode == 1, r.stderr
        assert "GiB" in r.stderr and f"{w}x{h}" in r.stderr, r.stderr
        assert "bad_alloc" not in r.stderr and "must be positive" not in r.stderr
    # The estimate: 48 bytes per pixel (image_budget.h).
    if size == (30000, 30000):
        assert "40.2 GiB" in r.stderr and "--max-memory" in r.stderr


def test_max_memory_is_the_budget(cli, wall, tmp_path):
    # 32 x 32 x 48 bytes = 48 KiB: refused under 40 KiB, rendered under 60 KiB.
    r = run(cli, *flag_render(wall, tmp_path / "a.png", "--max-memory", 40 / 1024 ** 2))
    assert r.returncode == 1 and "--max-memory" in r.stderr
    r = run(cli, *flag_render(wall, tmp_path / "a.png", "--max-memory", 60 / 1024 ** 2))
    assert r.returncode == 0, r.stderr


# --- truncated images --------------------------------------------------------------------------------

@pytest.mark.parametrize("ext", [".png", ".jpg", ".tif", ".exr"])
def test_truncated_environment_map_is_an_error(cli, ptir, wall, tmp_path, ext):
    rng = np.random.default_rng(3)
    env = tmp_path / ("env" + ext)
    ptir.write_image(str(env), rng.random((64, 128, 3)).astype(np.float32))
    data = env.read_bytes()
    env.write_bytes(data[: int(0.59 * len(data))])
    r = run(cli, *flag_render(wall, tmp_path / "x.exr", "--aov", "rgb", "--env", env))
    assert r.returncode == 1
    assert str(env) in r.stderr and "truncated or corrupt" in r.stderr
