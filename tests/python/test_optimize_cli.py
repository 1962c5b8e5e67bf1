"""`ptir optimize` and the Python optimiser: outputs, exact resume, Ctrl-C, errors.

The dataset is made here with the module itself: a sphere of flat Gaussians with a
warm top and a cool bottom under a sky with a sun, rendered from 6 views at 32x32
(TensoIR layout, RGBA PNG). Runs are tiny (a few iterations at 2 spp, 1 thread);
what is checked is the plumbing, not the recovery (tests/blender does that).
"""

import json
import math
import os
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from blender_kit import look_at
from ptir_testing import sphere_scene


@pytest.fixture(scope="module")
def dataset(ptir, tmp_path_factory):
    out = tmp_path_factory.mktemp("optimize_ds")
    frames = []
    for i in range(6):
        phi = 2 * math.pi * i / 6
        eye = (3.5 * math.cos(phi), 3.5 * math.sin(phi), 1.0 + 0.6 * (i % 2))
        frames.append({"file_path": "./train_%03d/rgba" % i, "transform_matrix": look_at(eye, (0, 0, 0)).tolist()})
    (out / "transforms_train.json").write_text(json.dumps({"camera_angle_x": 0.7, "w": 32, "h": 32, "frames": frames}))
    scene, p, _ = sphere_scene(ptir, out, 600, ((1.6, 0.15), (1.4, 0.12)), "transforms_train.json")
    scene.gaussians.roughness = np.where(p[:, 2] > 0, 0.3, 0.7).astype(np.float32)
    for i in range(6):
        img = scene.render(i, spp=32, bounces=2)
        (out / ("train_%03d" % i)).mkdir()
        ptir.write_image(str(out / ("train_%03d" % i) / "rgba.png"), img)
    return out


def optimize(cli, dataset, out, *extra, check=True):
    """Runs the CLI; `extra` options override the small defaults (2 spp, 1 thread, 16x8 environment)."""
    extra = [str(e) for e in extra]
    defaults = [opt for opt in (("--spp", "2"), ("--threads", "1"), ("--env-size", "16x8"), ("--fit-iters", "0"))
                if opt[0] not in extra]
    cmd = [str(cli), "optimize", "--dataset", str(dataset), "--gaussians", str(dataset / "g.ply"), "--out", str(out),
           *[x for opt in defaults for x in opt], *extra]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    if check:
        assert r.returncode == 0, r.stderr[-3000:]
    return r


def read_ply_properties(path):
    header = Path(path).read_bytes().split(b"end_header")[0].decode("ascii")
    return [line.split()[-1] for line in header.splitlines() if line.startswith("property")]


def state(ptir, out):
    g = ptir.load_gaussians(str(out / "gaussians.ply"))
    return g.albedo, g.roughness, g.normal, ptir.read_image(str(out / "env.exr"))


def test_outputs_and_progress(ptir, cli, dataset, tmp_path):
    out = tmp_path / "out"
    r = optimize(cli, dataset, out, "--iters", 6, "--checkpoint-every", 3, "--seed", 3)
    lines = [l for l in r.stderr.splitlines() if l.startswith("iter ")]
    assert len(lines) == 6
    assert "loss" in lines[0] and "s/iter" in lines[0] and "ETA" in lines[0]
    for name in ("gaussians.ply", "env.exr", "log.csv", "checkpoint.bin"):
        assert (out / name).is_file(), name
    assert not [p for p in out.iterdir() if ".tmp" in p.name]  # atomic writes leave no temp files
    props = read_ply_properties(out / "gaussians.ply")
    for name in read_ply_properties(dataset / "g.ply"):
        assert name in props  # every input property kept
    for name in ("albedo_0", "albedo_1", "albedo_2", "roughness", "metallic", "nx", "ny", "nz"):
        assert name in props
    g = ptir.load_gaussians(str(out / "gaussians.ply"))
    src = ptir.load_gaussians(str(dataset / "g.ply"))
    np.testing.assert_array_equal(g.position, src.position)
    assert not np.allclose(g.albedo, 0.3, atol=1e-3)  # materials moved
    assert np.all(g.metallic == 0)
    n = g.normal
    assert np.allclose(np.linalg.norm(n, axis=1), 1, atol=1e-4)
    seen = g.position[:, 2] > -0.3  # the cameras are above z = 1: the bottom cap is never seen directly
    assert np.all(np.sum(n * g.position, 1)[seen] > 0)  # oriented outward (toward the cameras)
    env = ptir.read_image(str(out / "env.exr"))
    assert env.shape == (8, 16, 3) and np.all(env > 0)
    rows = (out / "log.csv").read_text().splitlines()
    assert rows[0].startswith("iteration,loss,image,tv,prior,prior_weight,seconds")
    assert [int(r.split(",")[0]) for r in rows[1:]] == list(range(1, 7))


def test_resume_after_interruption_is_exact(ptir, cli, dataset, tmp_path):
    straight = tmp_path / "straight"
    # Schedules that do not depend on --iters (the light-albedo balance learning from the start; the defaults' are fractions of it, so a run extended
    # from 4 to 8 iterations continues on the 8-iteration schedule; an interrupted run with the same
    # --iters resumes exactly on any schedule: test_ctrl_c_writes_a_checkpoint_and_resume_finishes_exactly).
    flat = ("--lr-final", 1, "--albedo-warmup", 0, "--balance-start", 0)
    optimize(cli, dataset, straight, "--iters", 8, "--seed", 5, "--views-per-iter", 2, "--crop", 24, *flat)
    # The same run stopped after 4 iterations, then resumed to 8.
    part = tmp_path / "part"
    optimize(cli, dataset, part, "--iters", 4, "--seed", 5, "--views-per-iter", 2, "--crop", 24, *flat)
    r = optimize(cli, dataset, part, "--iters", 8, "--seed", 5, "--views-per-iter", 2, "--crop", 24, "--resume", *flat)
    assert "resumed from" in r.stderr and "iteration 4" in r.stderr
    for a, b in zip(state(ptir, straight), state(ptir, part)):
        np.testing.assert_array_equal(a, b)
    la = [l.split(",")[:6] for l in (straight / "log.csv").read_text().splitlines()]
    lb = [l.split(",")[:6] for l in (part / "log.csv").read_text().splitlines()]
    assert [row[:2] for row in la] == [row[:2] for row in lb]  # iterations and losses (not the timings)


def test_resume_refuses_a_different_problem(cli, dataset, tmp_path):
    out = tmp_path / "out"
    optimize(cli, dataset, out, "--iters", 2)
    r = optimize(cli, dataset, out, "--iters", 4, "--spp", 3, "--resume", check=False)
    assert r.returncode == 1
    assert "spp: checkpoint 2, now 3" in r.stderr
    r = optimize(cli, dataset, tmp_path / "none", "--iters", 4, "--resume", check=False)
    assert r.returncode == 1 and "no checkpoint" in r.stderr


def test_ctrl_c_writes_a_checkpoint_and_resume_finishes_exactly(ptir, cli, dataset, tmp_path):
    straight = tmp_path / "straight"
    optimize(cli, dataset, straight, "--iters", 12, "--spp", 8, "--seed", 2)
    out = tmp_path / "out"
    cmd = [str(cli), "optimize", "--dataset", str(dataset), "--gaussians", str(dataset / "g.ply"), "--out", str(out),
           "--spp", "8", "--threads", "1", "--env-size", "16x8", "--iters", "12", "--seed", "2", "--fit-iters", "0"]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)
    # Interrupt after the second iteration's progress line.
    seen = 0
    while seen < 2:
        line = proc.stderr.readline()
        assert line, "optimize ended before it could be interrupted"
        seen += line.startswith("iter ")
    proc.send_signal(signal.SIGINT)
    rest = proc.stderr.read()
    assert proc.wait(timeout=120) == 130, rest
    assert "interrupted after iteration" in rest
    ckpt_iters = int(rest.split("interrupted after iteration ")[1].split(";")[0])
    assert 2 <= ckpt_iters < 12
    for name in ("gaussians.ply", "env.exr", "log.csv", "checkpoint.bin"):
        assert (out / name).is_file(), name
    assert len((out / "log.csv").read_text().splitlines()) == ckpt_iters + 1
    optimize(cli, dataset, out, "--iters", 12, "--spp", 8, "--seed", 2, "--resume")
    for a, b in zip(state(ptir, straight), state(ptir, out)):
        np.testing.assert_array_equal(a, b)


def test_clear_errors(cli, dataset, tmp_path):
    r = optimize(cli, tmp_path / "missing", tmp_path / "o", "--iters", 1, check=False)
    assert r.returncode == 1 and "dataset folder not found" in r.stderr
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "transforms_train.json").write_text('{"camera_angle_x": 0.7, "frames": [')
    r = subprocess.run([str(cli), "optimize", "--dataset", str(bad), "--gaussians", str(dataset / "g.ply"), "--out",
                        str(tmp_path / "o")], capture_output=True, text=True)
    assert r.returncode == 1 and "transforms_train.json" in r.stderr and "invalid JSON" in r.stderr
    r = subprocess.run([str(cli), "optimize", "--dataset", str(dataset), "--gaussians", str(dataset / "g.ply"), "--out",
                        str(tmp_path / "o"), "--env", "cubemap"], capture_output=True, text=True)
    assert r.returncode == 1 and "--env must be 'latlong', 'sg', 'color' or 'none'" in r.stderr
    r = subprocess.run([str(cli), "optimize", "--dataset", str(dataset), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "--gaussians" in r.stderr


def test_sg_environment(ptir, cli, dataset, tmp_path):
    out = tmp_path / "sg"
    optimize(cli, dataset, out, "--iters", 3, "--env", "sg")
    env = ptir.read_image(str(out / "env.exr"))
    assert env.shape == (8, 16, 3)
    lobes = json.loads((out / "env_sg.json").read_text())["lobes"]
    assert len(lobes) == 24 and all(len(l["raw"]) == 3 for l in lobes)


def test_python_optimizer_callback_and_cancel(ptir, dataset, tmp_path):
    ds = ptir.load_dataset(str(dataset))
    assert len(ds) == 6 and ds.width == 32 and ds.view_names[0] == "train_000"
    rgb, alpha, has_alpha = ds.target(0)
    assert rgb.shape == (32, 32, 3) and alpha.shape == (32, 32) and has_alpha
    opt = ptir.Optimizer(ds, str(dataset / "g.ply"), iters=10, spp=2, env_size=(16, 8), threads=1)
    seen = []

    def callback(info):
        seen.append(info["iteration"])
        assert set(info) >= {"loss", "image", "tv", "prior", "seconds", "views"}
        return info["iteration"] < 3  # stop after the third

    out = tmp_path / "py"
    assert opt.run(out=str(out), callback=callback) == "cancelled"
    assert seen == [1, 2, 3] and opt.iteration == 3
    assert (out / "checkpoint.bin").is_file() and (out / "gaussians.ply").is_file()
    assert opt.gaussians.albedo.shape == (600, 3)
    assert opt.environment.shape == (8, 16, 3)
    # Continue in the same object to the end.
    assert opt.run(out=str(out)) == "finished"
    assert opt.iteration == 10 and len(opt.log) == 10
    # An uninterrupted run in a fresh object ends in the same state.
    again = ptir.Optimizer(ds, str(dataset / "g.ply"), iters=10, spp=2, env_size=(16, 8), threads=1)
    assert again.run() == "finished"
    np.testing.assert_array_equal(again.gaussians.albedo, opt.gaussians.albedo)

    # An exception in the callback stops the run and is re-raised after the outputs are written.
    opt2 = ptir.Optimizer(ds, str(dataset / "g.ply"), iters=5, spp=2, env_size=(16, 8), threads=1)

    def boom(info):
        raise ValueError("stop here")

    with pytest.raises(ValueError, match="stop here"):
        opt2.run(out=str(tmp_path / "boom"), callback=boom)
    assert opt2.iteration == 1 and (tmp_path / "boom" / "checkpoint.bin").is_file()

    r = ptir.optimize(str(dataset), str(dataset / "g.ply"), str(tmp_path / "fn"), iters=2, spp=2, env_size=(16, 8),
                      threads=1)
    assert r["result"] == "finished" and r["iteration"] == 2 and len(r["log"]) == 2


def test_prior_maps_enter_the_objective(ptir, cli, dataset, tmp_path):
    prior = tmp_path / "prior"
    for i in range(6):
        d = prior / ("train_%03d" % i)
        d.mkdir(parents=True)
        ptir.write_image(str(d / "albedo.png"), np.full((32, 32, 3), 0.5, np.float32))
        ptir.write_image(str(d / "roughness.png"), np.full((32, 32), 0.4, np.float32), colour=False)
    ds = ptir.load_dataset(str(dataset), prior=str(prior))
    assert ds.prior_albedo(0).shape == (32, 32, 3) and abs(float(ds.prior_albedo(0)[5, 5, 0]) - 0.5) < 0.01
    assert abs(float(ds.prior_roughness(0)[5, 5]) - 0.4) < 0.01  # data, not sRGB
    out = tmp_path / "out"
    r = optimize(cli, dataset, out, "--iters", 3, "--prior", prior)
    assert "(with priors)" in r.stderr
    rows = [l.split(",") for l in (out / "log.csv").read_text().splitlines()[1:]]
    weights = [float(row[5]) for row in rows]
    assert weights == pytest.approx([0.5 + (0.005 - 0.5) * i / 400 for i in range(3)])
    assert all(float(row[4]) > 0 for row in rows)  # the prior term
    r = optimize(cli, dataset, tmp_path / "o2", "--iters", 1, "--prior", tmp_path / "nothing", check=False)
    assert r.returncode == 1 and "prior folder not found" in r.stderr


def ply_count(path):
    for line in Path(path).read_bytes().split(b"end_header")[0].decode("ascii", "replace").splitlines():
        if line.startswith("element vertex"):
            return int(line.split()[2])
    raise AssertionError("no vertex element in %s" % path)


def test_geometry_stage_runs_first_by_default(ptir, cli, dataset, tmp_path):
    """The inversion runs on the splats the geometry stage fitted (OUT/fit/), and a
    resumed inversion keeps them; --fit-iters 0 keeps the input's geometry. The
    bounce light comes from the fitted splats' SH (--indirect auto), and is
    path-traced on splats as given."""
    out = tmp_path / "fitted"
    r = optimize(cli, dataset, out, "--iters", 2, "--fit-iters", 30)
    assert "fit: 600 Gaussians" in r.stderr, r.stderr[-2000:]
    assert "(indirect: field)" in r.stderr, r.stderr[-2000:]
    fit_log = (out / "fit" / "log.csv").read_text().splitlines()
    assert len(fit_log) == 31 and fit_log[-1].startswith("30,")
    n_fit = ply_count(out / "fit" / "gaussians.ply")
    assert ply_count(out / "gaussians.ply") == n_fit
    fitted = ptir.load_gaussians(str(out / "fit" / "gaussians.ply"))
    given = ptir.load_gaussians(str(dataset / "g.ply"))
    assert np.abs(np.asarray(fitted.position)[:600] - np.asarray(given.position)).max() > 1e-4  # the fit moved them
    r = optimize(cli, dataset, out, "--iters", 4, "--fit-iters", 30, "--resume")
    assert "fit:" not in r.stderr and "resumed from" in r.stderr
    assert "(indirect: field)" in r.stderr
    assert ply_count(out / "gaussians.ply") == n_fit
    # The checkpoint knows how its bounce light was made: path-traced cannot continue it.
    r = optimize(cli, dataset, out, "--iters", 5, "--fit-iters", 30, "--resume", "--indirect", "path", check=False)
    assert r.returncode != 0 and "indirect: only in the checkpoint (field)" in r.stderr, r.stderr[-2000:]
    # A path-traced run (here on the splats as given) resumes path-traced under auto.
    given = tmp_path / "given"
    optimize(cli, dataset, given, "--iters", 2, "--checkpoint-every", 1)
    r = optimize(cli, dataset, given, "--iters", 3, "--resume")
    assert "(indirect: path)" in r.stderr and "resumed from" in r.stderr, r.stderr[-2000:]
    plain = tmp_path / "plain"
    r = optimize(cli, dataset, plain, "--iters", 2)  # (the helper's default: --fit-iters 0)
    assert not (plain / "fit").exists() and ply_count(plain / "gaussians.ply") == 600
    assert "(indirect: path)" in r.stderr
    r = optimize(cli, dataset, tmp_path / "bad", "--iters", 1, "--indirect", "splats", check=False)
    assert r.returncode != 0 and "--indirect must be 'auto', 'path' or 'field', got 'splats'" in r.stderr


def test_loss_space_default_and_resume(cli, dataset, tmp_path):
    """New runs take the sRGB curve after the loss's blur (srgb-blur-first); a resumed
    run keeps the loss space its checkpoint began with, so a run of an earlier
    release (plain srgb) goes on as it began, and a different one given outright is
    refused by the fingerprint."""
    r = optimize(cli, dataset, tmp_path / "new", "--iters", 1)
    assert "loss srgb-blur-first," in r.stderr, r.stderr[-2000:]
    old = tmp_path / "old"
    optimize(cli, dataset, old, "--iters", 2, "--checkpoint-every", 1, "--loss-space", "srgb")
    r = optimize(cli, dataset, old, "--iters", 3, "--resume")
    assert "loss srgb," in r.stderr and "resumed from" in r.stderr, r.stderr[-2000:]
    r = optimize(cli, dataset, old, "--iters", 4, "--resume", "--loss-space", "srgb-blur-first", check=False)
    assert r.returncode != 0 and "loss" in r.stderr, r.stderr[-2000:]
    r = optimize(cli, dataset, tmp_path / "bad", "--iters", 1, "--loss-space", "gamma", check=False)
    assert r.returncode != 0
    assert "must be 'srgb-blur-first', 'srgb' or 'linear', got 'gamma'" in r.stderr, r.stderr[-2000:]


def test_geometry_stage_is_skipped_for_scenes_with_meshes(cli, dataset, tmp_path):
    wall = tmp_path / "wall.ply"
    wall.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                    "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                    "5 -5 -5\n5 5 -5\n5 0 5\n3 0 1 2\n")
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps({"version": 1, "meshes": [{"name": "wall", "file": "wall.ply"}]}))
    out = tmp_path / "o"
    r = optimize(cli, dataset, out, "--iters", 1, "--fit-iters", 30, "--scene", scene)
    assert "geometry fit skipped: the scene has meshes" in r.stderr
    assert not (out / "fit").exists() and ply_count(out / "gaussians.ply") == 600


def test_init_from_ply_starts_at_the_files_materials(ptir, cli, dataset, tmp_path):
    # A PLY carrying materials (a previous result, or the truth) as the start: with
    # rates too small to move anything in 2 iterations, the output is the input's
    # albedo and roughness; without the flag, the constants (0.3, 0.6).
    src = ptir.load_gaussians(str(dataset / "g.ply"))
    rng = np.random.default_rng(0)
    src.albedo = rng.uniform(0.1, 0.9, (len(src), 3)).astype(np.float32)
    src.roughness = rng.uniform(0.2, 0.9, len(src)).astype(np.float32)
    start = tmp_path / "start.ply"
    ptir.save_gaussians(str(start), src)
    slow = ["--iters", 2, "--lr-albedo", 1e-9, "--lr-roughness", 1e-9, "--light-balance", 0, "--gaussians", start]
    cmd_out = {}
    for flag in ("--init-from-ply", None):
        out = tmp_path / ("from_ply" if flag else "constants")
        extra = slow + ([flag] if flag else [])
        cmd = [str(cli), "optimize", "--dataset", str(dataset), "--out", str(out), "--spp", "2", "--threads", "1",
               "--env-size", "16x8", "--fit-iters", "0", *[str(e) for e in extra]]
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr[-3000:]
        cmd_out[flag] = ptir.load_gaussians(str(out / "gaussians.ply"))
    g = cmd_out["--init-from-ply"]
    np.testing.assert_allclose(g.albedo, src.albedo, atol=1e-4)
    np.testing.assert_allclose(g.roughness, src.roughness, atol=1e-4)
    c = cmd_out[None]
    np.testing.assert_allclose(c.albedo, 0.3, atol=1e-4)
    np.testing.assert_allclose(c.roughness, 0.6, atol=1e-4)


def test_help_lists_the_common_options_and_help_all_every_one(cli):
    """`--help` stays short (the README says what it lists); `--help-all` keeps every option
    reachable; options measured and removed are gone from both (docs/inversion.md)."""
    def options(flag):
        r = subprocess.run([str(cli), "optimize", flag], capture_output=True, text=True, timeout=30)
        assert r.returncode == 0, r.stderr
        return r.stdout, [line.split()[0] for line in r.stdout.splitlines() if line.startswith("  -")]

    text, common = options("--help")
    _, every = options("--help-all")
    assert len(common) <= 26 and "--dataset" in " ".join(common) and "--help-all" in common, common
    assert "--lr-env" not in " ".join(common) and "--lr-env" in " ".join(every)
    assert set(common) < set(every) and "ptir optimize --help-all" in text
    for removed in ("--light-solve", "--lambda-env-smooth", "--lambda-env-chroma", "--env-fine-warmup",
                    "--ssim-cross", "--env-adam", "--average-from", "--huber-delta"):
        assert not any(o.startswith(removed) for o in every), removed
