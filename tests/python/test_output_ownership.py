"""Nothing lost on the newer surfaces (issue 54; docs/robustness.md): who may write an output folder,
what goes into it, and when, through the real CLI.

- one writer per output folder: a second `optimize` on a folder in use fails naming the first one's
  pid; the lock dies with its owner (kill -9), and a finished folder keeps no lock file;
- no result among a dataset's files, passed as --dataset or not; no input (--cameras) inside the output;
- PLY-only runs: a budgeted run resumes; the plan and its targets change together or not at all (a full
  disk midway keeps the old ones); targets that the inversion's mask never takes fail naming the PLY;
- `eval` writes its folder whole (a full disk leaves the previous evaluation); `--estimate` writes
  nothing in OUT;
- budgets are durations from 1 s to 30 days, planned without overflow.

The PLY-only runs take the optimiser tests' sphere of 600 splats (test_optimize_cli.py) with a
4-view, 32-pixel orbit: about a second each on one thread.
"""

import json
import math
import os
import shutil
import subprocess

import numpy as np
import pytest

from ptir_testing import quat_z_to, write_splat_ply
from test_optimize_cli import dataset, optimize  # noqa: F401  (the module's fixture and runner)
from test_robustness_cli import fill, small_fs  # noqa: F401  (the 1 MiB tmpfs)

QUICK = ["--orbit-views", "4", "--orbit-size", "32", "--target-spp", "1", "--env-size", "16x8", "--threads", "1"]


def run(cli, *args, timeout=300):
    return subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True, timeout=timeout)


def ply_only(cli, ply, out, *extra):
    """`ptir optimize` without --dataset at the quick setting; `extra` adds or overrides flags."""
    extra = [str(e) for e in extra]
    quick = [x for k, v in zip(QUICK[::2], QUICK[1::2]) if k not in extra for x in (k, v)]
    return run(cli, "optimize", "--gaussians", ply, "--out", out, *quick, *extra)


def snapshot(folder):
    """Every file under `folder`, relative name -> bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


# --- kind 1: a budgeted PLY-only run resumes -----------------------------------------------------------

def test_a_budgeted_ply_only_run_resumes(cli, dataset, tmp_path):  # noqa: F811
    out = tmp_path / "b"
    r = ply_only(cli, dataset / "g.ply", out, "--budget", "4s")
    assert r.returncode == 0, r.stderr[-2000:]
    planned = json.loads((out / "budget.json").read_text())["spp"]
    # The PLY-only default (16 spp) went over the spp the budget had planned: "spp: checkpoint 8, now 16".
    r = ply_only(cli, dataset / "g.ply", out, "--budget", "8s", "--resume")
    assert r.returncode == 0, r.stderr[-2000:]
    assert "resumed from" in r.stderr and json.loads((out / "budget.json").read_text())["spp"] == planned


# --- kind 2: one writer per output folder ----------------------------------------------------------------

def test_one_writer_per_output_folder(cli, dataset, tmp_path):  # noqa: F811
    out = tmp_path / "shared"
    first = subprocess.Popen([str(cli), "optimize", "--dataset", str(dataset), "--gaussians", str(dataset / "g.ply"),
                              "--out", str(out), "--iters", "100000", "--spp", "1", "--threads", "1", "--env-size",
                              "16x8", "--fit-iters", "0", "--checkpoint-every", "0"],
                             stderr=subprocess.PIPE, text=True)
    try:
        for line in first.stderr:  # until it iterates (it holds the folder from its start)
            if line.startswith("iter "):
                break
        assert first.poll() is None
        second = optimize(cli, dataset, out, "--iters", "1", check=False)
        assert second.returncode == 1, second.stderr[-2000:]  # was 0, the two runs' files mixed
        assert str(out) in second.stderr and "pid %d" % first.pid in second.stderr, second.stderr
        assert "ptir optimize" in second.stderr
        # eval of the result being written, and fit into it, wait their turn too.
        r = run(cli, "fit", "--dataset", dataset, "--gaussians", dataset / "g.ply", "--out", out, "--iters", "1")
        assert r.returncode == 1 and "pid %d" % first.pid in r.stderr, r.stderr
        r = run(cli, "eval", "--dataset", dataset, "--split", "train", "--result", out, "--spp", "1")
        assert r.returncode == 1 and "pid %d" % first.pid in r.stderr, r.stderr
        assert not (out / "eval").exists()
    finally:
        first.kill()  # kill -9: the kernel drops its lock
        first.wait()
    assert (out / ".ptir-lock").exists()  # left by the killed run, and stale
    optimize(cli, dataset, out, "--iters", "1")
    assert not (out / ".ptir-lock").exists()  # a finished run leaves none


# --- kinds 6 and 7: a result never among a dataset's files, an input never inside the output --------------

def test_ply_only_out_is_never_a_dataset(cli, dataset, tmp_path):  # noqa: F811
    data = tmp_path / "photos"
    shutil.copytree(dataset, data)
    ply = tmp_path / "splats.ply"
    shutil.copy(data / "g.ply", ply)
    photos_only = tmp_path / "jpgs"
    photos_only.mkdir()
    for i in range(3):
        shutil.copy(data / ("train_%03d" % i) / "rgba.png", photos_only / ("IMG_%d.png" % i))
    for folder in (data, photos_only):
        before = snapshot(folder)
        r = ply_only(cli, ply, folder, "--iters", "1")
        assert r.returncode == 1, r.stderr[-2000:]  # was 0: gaussians.ply replaced, checkpoints among the photos
        assert str(folder) in r.stderr and "dataset" in r.stderr, r.stderr
        assert snapshot(folder) == before
    # fit and optimize with photos follow the same rule.
    r = run(cli, "fit", "--dataset", dataset, "--gaussians", ply, "--out", data, "--iters", "1")
    assert r.returncode == 1 and "dataset" in r.stderr, r.stderr
    # An empty folder and a result of ours are fine (and --force writes anyway).
    (tmp_path / "empty").mkdir()
    assert ply_only(cli, ply, tmp_path / "empty", "--iters", "1").returncode == 0
    assert ply_only(cli, ply, tmp_path / "empty", "--iters", "1").returncode == 0


def test_cameras_inside_the_output_are_refused(cli, dataset, tmp_path):  # noqa: F811
    out = tmp_path / "out"
    out.mkdir()
    cams = [{"id": i, "img_name": "v%d" % i, "width": 32, "height": 32, "fx": 40.0, "fy": 40.0,
             "position": [3.5 * math.cos(i), 3.5 * math.sin(i), 0.0],
             "rotation": np.linalg.qr(np.random.default_rng(i).normal(size=(3, 3)))[0].tolist()} for i in range(3)]
    views = out / "views.json"
    views.write_text(json.dumps(cams))
    before = views.read_bytes()
    r = ply_only(cli, dataset / "g.ply", out, "--cameras", views, "--iters", "1")
    assert r.returncode == 1, r.stderr[-2000:]  # was 0, and views.json replaced by the plan
    assert str(views) in r.stderr and "input" in r.stderr, r.stderr
    assert views.read_bytes() == before


# --- kind 8: the PLY-only plan and eval's folder are written whole ------------------------------------------

def test_a_full_disk_keeps_the_ply_only_plan_whole(cli, dataset, small_fs):  # noqa: F811
    out = small_fs / "out"
    r = ply_only(cli, dataset / "g.ply", out, "--iters", "1")
    assert r.returncode == 0, r.stderr[-2000:]
    before = snapshot(out)
    # Room for the new plan's views.json and a target or two, not for all of a 12-view plan.
    fill(small_fs, leave=3 * len(before["radiance/train/view_000.exr"]))
    r = ply_only(cli, dataset / "g.ply", out, "--iters", "1", "--orbit-views", "12")
    assert r.returncode == 1, r.stderr[-2000:]
    assert snapshot(out) == before  # was: the new plan's views.json and radiance/ beside the old result
    assert not (out / ".plan-staging").exists()
    # Room for a 5-view plan's targets, not for the results after them: the same.
    (small_fs / "filler").unlink()
    page = lambda n: -(-n // 4096) * 4096  # noqa: E731  (tmpfs allocates pages)
    plan = sum(page(len(v)) for k, v in before.items() if k.startswith("radiance/")) + page(len(before["views.json"]))
    results = sum(page(len(before[k])) for k in ("checkpoint.bin", "gaussians.ply"))
    print("plan", plan, "results", results)
    fill(small_fs, leave=2 * plan + results // 2)
    r = ply_only(cli, dataset / "g.ply", out, "--iters", "1", "--orbit-views", "5")
    assert r.returncode == 1 and "5 views rendered" in r.stderr, r.stderr[-2000:]
    assert snapshot(out) == before  # the plan goes in place with the results, or not at all
    assert not (out / ".plan-staging").exists()


def test_a_failed_eval_keeps_the_previous_evaluation(cli, dataset, small_fs):  # noqa: F811
    data = small_fs.parent / "data"
    shutil.copytree(dataset, data)
    test = json.loads((data / "transforms_train.json").read_text())
    (data / "transforms_test.json").write_text(json.dumps(test))
    result = small_fs / "result"
    optimize(cli, data, result, "--iters", "1")
    ev = ["eval", "--dataset", data, "--result", result, "--spp", "2", "--aov-spp", "1", "--threads", "1", "-q"]
    assert run(cli, *ev).returncode == 0
    before = snapshot(result / "eval")
    # A failure midway: the last view's ground truth is damaged (eval reads each view's as it goes).
    good = (data / "train_005" / "rgba.png").read_bytes()
    (data / "train_005" / "rgba.png").write_bytes(good[:200])
    r = run(cli, *ev, "--seed", "7")
    assert r.returncode == 1 and "train_005" in r.stderr, r.stderr[-2000:]
    assert snapshot(result / "eval") == before  # was: five views' new renders beside the old metrics.json
    assert not (result / ".eval-staging").exists()
    # A full disk midway: the same (the new evaluation needs room beside the old one until it replaces it).
    (data / "train_005" / "rgba.png").write_bytes(good)
    view = sum(len(v) for k, v in before.items() if k.startswith("test_000/"))
    fill(small_fs, leave=2 * view)  # room for a view or two of the six
    r = run(cli, *ev, "--seed", "7")
    assert r.returncode == 1 and "writing failed" in r.stderr, r.stderr[-2000:]
    assert snapshot(result / "eval") == before
    assert not (result / ".eval-staging").exists()
    (small_fs / "filler").unlink()
    assert run(cli, *ev, "--seed", "7").returncode == 0
    after = snapshot(result / "eval")
    assert after.keys() == before.keys() and after != before  # the new evaluation, whole


# --- kind 9: --estimate writes nothing in OUT ----------------------------------------------------------------

def test_estimate_writes_nothing_in_out(cli, dataset, tmp_path):  # noqa: F811
    out = tmp_path / "res"
    assert ply_only(cli, dataset / "g.ply", out, "--iters", "1").returncode == 0
    before = snapshot(out)
    r = ply_only(cli, dataset / "g.ply", out, "--orbit-views", "6", "--estimate")
    assert r.returncode == 0, r.stderr[-2000:]
    est = json.loads(next(l for l in r.stdout.splitlines() if l.startswith('{"estimate"')))["estimate"]
    assert est["views"] == 1 and est["total_s"] > 0
    assert snapshot(out) == before  # was: a new views.json and radiance_estimate/
    fresh = tmp_path / "fresh"
    assert ply_only(cli, dataset / "g.ply", fresh, "--estimate").returncode == 0
    assert not fresh.exists()


# --- kind 10: budgets are durations in a sane range -----------------------------------------------------------

@pytest.mark.parametrize("budget", ["1e9h", "2147483648s", "1e-300s", "0.5s", "31d", "721h", "inf", "nan", "0x10",
                                    " 5m", "-5m"])
def test_budgets_out_of_range_are_refused(cli, dataset, tmp_path, budget):  # noqa: F811
    r = optimize(cli, dataset, tmp_path / "o", "--budget", budget, check=False)
    assert r.returncode == 1, (budget, r.returncode, r.stderr[-2000:])  # 1e9h planned 1 iteration, exit 0
    assert "--budget" in r.stderr and budget in r.stderr, r.stderr
    assert not (tmp_path / "o").exists()
    r = run(cli, "fit", "--dataset", dataset, "--gaussians", dataset / "g.ply", "--out", tmp_path / "f", "--budget",
            budget)
    assert r.returncode == 1 and "--budget" in r.stderr, r.stderr


def test_a_budget_that_fits_no_iteration_fails(cli, dataset, tmp_path):  # noqa: F811
    # 1 s is in range, but loading and the probe take some of it and 2 s are kept for the outputs.
    r = optimize(cli, dataset, tmp_path / "o", "--budget", "1s", check=False)
    assert r.returncode == 1, r.stderr[-2000:]  # was 0, writing the untrained materials
    assert "no iteration fits" in r.stderr and not (tmp_path / "o" / "gaussians.ply").exists(), r.stderr


# --- kind 11: targets the inversion's mask never takes -------------------------------------------------------

def test_ply_only_on_splats_that_never_cover_a_pixel_fails(cli, tmp_path):
    n = 600
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = math.pi * (1 + 5 ** 0.5) * k
    pos = np.column_stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z])
    spacing = math.sqrt(4 * math.pi / n)
    ply = write_splat_ply(tmp_path / "faint.ply", pos, (0.7 * spacing, 0.7 * spacing, 1e-3 * spacing),
                          quat=quat_z_to(pos), opacity=0.1, colour=(0.7, 0.4, 0.2), sh_rest=0)
    out = tmp_path / "out"
    r = ply_only(cli, ply, out, "--iters", "3")
    assert r.returncode == 1, r.stderr[-2000:]  # was 0: 3 iterations at loss 0 and the priors written
    assert str(ply) in r.stderr and "alpha" in r.stderr and "0.99" in r.stderr, r.stderr
    assert not (out / "gaussians.ply").exists() and not (out / "radiance").exists()
    # The same splats opaque train (the check is on coverage, not on the PLY).
    opaque = write_splat_ply(tmp_path / "solid.ply", pos, (0.7 * spacing, 0.7 * spacing, 1e-3 * spacing),
                             quat=quat_z_to(pos), opacity=0.95, colour=(0.7, 0.4, 0.2), sh_rest=0)
    r = ply_only(cli, opaque, tmp_path / "solid", "--iters", "3")
    assert r.returncode == 0, r.stderr[-2000:]
