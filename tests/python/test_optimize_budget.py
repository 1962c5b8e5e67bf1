"""`ptir optimize --budget` (optim/budget_plan.h, pipeline/optimize_budget.h): the plan, the
record --resume continues from, and the errors. Runs are a few seconds on the tiny
sphere set of test_optimize_cli.py (6 views of 32x32, 1 thread). How close a budget
lands to its time is a benchmark (bench/time_to_quality.py), not asserted here."""

import json
import math
import re
import shutil

import numpy as np

from blender_kit import look_at

from test_optimize_cli import dataset, optimize  # noqa: F401  (the module's fixture and runner)


def _iterations(out):
    with open(out / "log.csv") as f:
        return len(f.read().splitlines()) - 1


def test_budget_plans_the_run_and_resume_continues_it(cli, dataset, tmp_path):  # noqa: F811
    out = tmp_path / "b"
    r = optimize(cli, dataset, out, "--budget", "8s", "--spp", "8")
    assert "budget 8 s" in r.stderr and "iterations at" in r.stderr, r.stderr[-2000:]
    rec = json.loads((out / "budget.json").read_text())
    n1 = _iterations(out)
    assert rec["budget_s"] == 8.0 and rec["spp"] >= 1 and n1 >= 1  # (how many: the machine's load)
    # The pacer plans the end at the budget less 2 s for the outputs; one iteration here is
    # well under 0.1 s, so the last recorded time is inside the budget (not a timing bound:
    # the re-plan after every iteration guarantees it for any steady rate).
    assert 0.0 < rec["spent_s"] <= rec["budget_s"]
    # --resume with a larger budget: what is left of it, at the same spp, from the same checkpoint.
    r = optimize(cli, dataset, out, "--budget", "16s", "--spp", "8", "--resume")
    assert "resumed from" in r.stderr, r.stderr[-2000:]
    rec2 = json.loads((out / "budget.json").read_text())
    assert rec2["budget_s"] == 16.0 and rec2["spp"] == rec["spp"]
    assert rec2["spent_s"] > rec["spent_s"] and _iterations(out) > n1
    # A fresh run without a budget leaves no stale record behind.
    optimize(cli, dataset, out, "--iters", "2")
    assert not (out / "budget.json").exists()


def test_budget_estimate_and_errors(cli, dataset, tmp_path):  # noqa: F811
    r = optimize(cli, dataset, tmp_path / "e", "--budget", "1m", "--estimate")
    est = json.loads(next(l for l in r.stdout.splitlines() if l.startswith('{"estimate"')))["estimate"]
    assert est["budget_s"] == 60.0 and est["iterations"] > 0 and est["spp"] >= 1
    assert est["total_s"] <= 60.0 * 1.01  # the plan fits the budget by its own estimate
    r = optimize(cli, dataset, tmp_path / "x", "--budget", "10 minutes", check=False)
    assert r.returncode != 0 and "--budget must be a positive duration" in r.stderr
    r = optimize(cli, dataset, tmp_path / "x", "--budget", "1m", "--iters", "5", check=False)
    assert r.returncode != 0 and "not both" in r.stderr


def test_fit_budget_stops_a_long_fit_early(cli, dataset, tmp_path):  # noqa: F811
    """`ptir fit --budget` (the geometry stage's share of a budget): at most --iters, fewer when
    they would not end in time -- 100000 iterations of ~10 ms cannot fit into 3 s."""
    import subprocess
    out = tmp_path / "fit"
    r = subprocess.run([str(cli), "fit", "--dataset", str(dataset), "--gaussians", str(dataset / "g.ply"), "--out",
                        str(out), "--iters", "100000", "--budget", "3s", "--threads", "1", "-q"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert 1 <= _iterations(out) < 100000 and (out / "gaussians.ply").exists()


def test_budget_runs_both_stages_on_the_resolution_pyramid(cli, dataset, tmp_path):  # noqa: F811
    """A budget takes the resolution pyramid (optim/view_pyramid.h): here --coarse-pixels 256
    reduces the 32x32 views to 16x16 for the first three quarters of both stages. The run
    records it (settings.json) and ends inside its budget with the two phases timed apart
    by the pacer."""
    out = tmp_path / "pyr"
    r = optimize(cli, dataset, out, "--budget", "8s", "--coarse-pixels", "256", "--fit-iters", "40")
    assert "budget 8 s" in r.stderr, r.stderr[-2000:]
    # The geometry stage plans its fine fraction after 8 coarse iterations: 32 more of these
    # (milliseconds each) at full resolution fit its share easily, so all of them are
    # (fit_stage.h; 32/40 on the grid of 1/1024: 819/1024).
    assert "fit: 80 % of the iterations at full resolution" in r.stderr, r.stderr[-2000:]
    settings = json.loads((out / "settings.json").read_text())
    assert settings["pyramid"] == "256 until 0.75", settings
    rec = json.loads((out / "budget.json").read_text())
    assert 0.0 < rec["spent_s"] <= rec["budget_s"]
    assert _iterations(out) >= 1 and (out / "fit" / "gaussians.ply").exists()
    # Both phases' spp are planned (budget_plan.h's ladder) and kept for --resume.
    m = re.search(r"at (\d+) spp \((\d+) while coarse, the last 25 % at full resolution\)", r.stderr)
    assert m, r.stderr[-2000:]
    assert (rec["spp"], rec["coarse_spp"]) == (int(m.group(1)), int(m.group(2))), rec
    # The planned fine fraction is in the fit's checkpoint: a budgeted fit resumed keeps it
    # (without the inversion's checkpoint the resume goes back to the fit, done here, whose
    # fingerprint must match the plan, not the default quarter).
    (out / "checkpoint.bin").unlink()
    r = optimize(cli, dataset, out, "--budget", "16s", "--coarse-pixels", "256", "--fit-iters", "40", "--resume")
    assert "resumed from" in r.stderr and "of the iterations at full resolution" not in r.stderr, r.stderr[-2000:]
    assert _iterations(out) >= 1
    # --fine-fraction given: the fit keeps it (no plan).
    r = optimize(cli, dataset, tmp_path / "ff", "--budget", "8s", "--coarse-pixels", "256", "--fit-iters", "40",
                 "--fine-fraction", "0.5")
    assert "of the iterations at full resolution" not in r.stderr, r.stderr[-2000:]
    # Without a budget the pyramid is off unless asked for (an --iters run is unchanged).
    r = optimize(cli, dataset, tmp_path / "iters", "--iters", "3", "--fit-iters", "0")
    assert "pyramid" not in json.loads((tmp_path / "iters" / "settings.json").read_text())
    r = optimize(cli, dataset, tmp_path / "bad", "--iters", "3", "--coarse-pixels", "-5", check=False)
    assert r.returncode != 0 and "coarse" in r.stderr, r.stderr[-2000:]
    # The coarse phase's own spp, asked for: the fingerprint names it.
    optimize(cli, dataset, tmp_path / "cspp", "--iters", "4", "--fit-iters", "0", "--spp", "8",
             "--coarse-pixels", "256", "--coarse-spp", "4")
    assert json.loads((tmp_path / "cspp" / "settings.json").read_text())["pyramid"] == "256 until 0.75, coarse spp 4"
    r = optimize(cli, dataset, tmp_path / "bad2", "--iters", "3", "--coarse-spp", "-1", check=False)
    assert r.returncode != 0 and "--coarse-spp" in r.stderr, r.stderr[-2000:]


def _flat_views(ptir, out, n, side, splats):
    """n views of side² around the origin: a grey disk on a transparent film (its mask box
    is the disk's), enough for the plan's estimate, which renders only its probe windows."""
    out.mkdir()
    frames = []
    for i in range(n):
        phi = 2 * math.pi * i / n
        eye = (3.5 * math.cos(phi), 3.5 * math.sin(phi), 1.0 + 0.4 * (i % 3))
        frames.append({"file_path": "./train_%03d/rgba" % i, "transform_matrix": look_at(eye, (0, 0, 0)).tolist()})
    (out / "transforms_train.json").write_text(json.dumps({"camera_angle_x": 0.7, "w": side, "h": side, "frames": frames}))
    y, x = np.mgrid[0:side, 0:side]
    disk = ((x - side / 2) ** 2 + (y - side / 2) ** 2 < (side / 3) ** 2).astype(np.float32)
    img = np.dstack([0.4 * disk, 0.35 * disk, 0.3 * disk, disk]).astype(np.float32)
    for i in range(n):
        (out / ("train_%03d" % i)).mkdir()
        ptir.write_image(str(out / ("train_%03d" % i) / "rgba.png"), img)
    shutil.copy(splats, out / "g.ply")
    return out


def _budget_estimate(cli, d, out, *extra):
    """--estimate's plan for an 8-hour budget on the set in d."""
    r = optimize(cli, d, out, "--budget", "8h", "--estimate", *extra)
    return json.loads(next(l for l in r.stdout.splitlines() if l.startswith('{"estimate"')))["estimate"]


def test_budget_spends_samples_on_patches_where_the_photos_hold_more_pixels(ptir, cli, dataset, tmp_path):  # noqa: F811
    """budget_plan.h's spread_fine_samples: a long budget on views larger than the batch buys
    more patches of 32² per full-resolution iteration before more samples per pixel, as many
    as visit the training pixels in 800 x 0.25 iterations (48 views of 200²: 1.92 M pixels,
    ceil(1.92 M / (200 x 1024)) = 10), never past kMaxPatchViews (32); where the views hold
    no more than 8 patches visit (6 views), or the patch count is given, the batch stays 8."""
    def estimate(d, *extra):
        return _budget_estimate(cli, d, tmp_path / "e", *extra)

    many = _flat_views(ptir, tmp_path / "many", 48, 200, dataset / "g.ply")
    est = estimate(many)
    assert (est["views_per_iter"], est["crop"]) == (10, 32), est
    assert est["fine_share"] == 0.25, est  # 10 patches' worth: the quarter (the next test)
    assert est["spp"] >= 8 and est["coarse_spp"] > 0, est  # the pyramid's coarse phase keeps its own
    assert est["total_s"] <= 8 * 3600 * 1.01, est
    assert estimate(many, "--views-per-iter", "8")["views_per_iter"] == 8  # given: kept
    few = _flat_views(ptir, tmp_path / "few", 6, 200, dataset / "g.ply")
    est = estimate(few)
    assert (est["views_per_iter"], est["crop"]) == (6, 32), est  # the automatic batch: one patch a view
    assert est["fine_share"] == 0.25, est


def test_budget_keeps_the_quarter_at_full_resolution_on_a_rendered_set(ptir, cli, dataset, tmp_path):  # noqa: F811
    """budget_plan.h's data_fine_share is asked for real photos only (optimize_budget.cpp): a
    rendered set on a transparent film with more pixels than 32 patches visit in 800 x 0.25
    iterations (48 views of 400²: 7.7 M against 6.6 M) keeps the quarter, where a 512² set of 40
    views measured the half 0.25 dB lower on albedo. The photos' half: test_real_capture.py."""
    big = _flat_views(ptir, tmp_path / "big", 48, 400, dataset / "g.ply")
    est = _budget_estimate(cli, big, tmp_path / "e")
    assert (est["fine_share"], est["views_per_iter"]) == (0.25, 32), est
