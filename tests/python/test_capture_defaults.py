"""The defaults serve captures as they serve synthetic sets (issue 38): one
Cycles set from the dataset maker, and the same pixels, poses and masks written
as a COLMAP capture (scripts/nerf_to_colmap.py), give `ptir optimize` at its
default settings the same resolved settings (OUT/settings.json: environment,
surface model, pixel filter, loss, schedules, ...) and the same albedo when both
results are scored against the set's ground truth.

Before issue 38 the capture path differed twice: 24 SGs instead of the lat-long
environment, and the Principled model of the set's Blender (recorded in its
dataset.json) was read for NeRF layouts only, so the capture was inverted with
principled-v2 against Cycles 3.4's v1 images.
"""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from ptir_testing import BLENDER, REPO, needs_blender
from ptir_testing import run_checked as run

pytestmark = needs_blender

sys.path.insert(0, str(REPO / "scripts"))
import nerf_to_colmap  # noqa: E402

# Short runs, every other option at its default (geometry stage included): the
# question is whether the two layouts get the same run, not the run's quality.
ITERS, FIT_ITERS = ["--iters", "60"], ["--fit-iters", "100"]
# Entries that name the inputs, not a setting: the layout itself and hashes of
# the cameras (their names differ: "001_train_000" against "train_000") and of the
# fitted splats (poses through COLMAP's quaternions differ by ~2e-7).
INPUT_ENTRIES = {"layout", "views_hash", "geometry_hash"}


@pytest.fixture(scope="module")
def pair(tmp_path_factory, cli):
    root = tmp_path_factory.mktemp("capture_defaults")
    nerf, colmap = root / "nerf", root / "colmap"
    run([*BLENDER, "-P", REPO / "scripts" / "make_dataset.py", "--", "--out", nerf, "--res", "48", "--train", "12",
         "--test", "2", "--spp", "32", "--subdiv", "1", "--textured", "--relight-envs", "", "--threads", "2"], timeout=600)
    names = nerf_to_colmap.convert(nerf, colmap)
    results = {}
    for layout, data in (("nerf", nerf), ("colmap", colmap)):
        out = root / ("result_" + layout)
        run([cli, "optimize", "--dataset", data, "--gaussians", nerf / "gaussians.ply", "--out", out, *ITERS, *FIT_ITERS,
             "-q"], timeout=600)
        run([cli, "eval", "--dataset", nerf, "--result", out, "--spp", "16", "-q"], timeout=300)
        results[layout] = {"settings": json.loads((out / "settings.json").read_text()),
                           "metrics": json.loads((out / "eval" / "metrics.json").read_text())}
    return {"nerf": nerf, "colmap": colmap, "names": names, "results": results}


def test_the_capture_holds_the_sets_training_views(ptir, pair):
    # 12 training views need 2 test views at positions 0 and 8: the default holdout keeps exactly the set's.
    assert pair["names"][0] == "test_000" and pair["names"][8] == "test_001" and len(pair["names"]) == 14
    a = ptir.load_dataset(str(pair["nerf"]), split="train")
    b = ptir.load_dataset(str(pair["colmap"]), split="train")
    assert b.layout == "colmap" and len(b.cameras) == len(a.cameras) == 12
    for ca, cb in zip(a.cameras, b.cameras):
        assert cb.name.endswith(ca.name)
        np.testing.assert_allclose(np.array(cb.camera_to_world), np.array(ca.camera_to_world), atol=1e-5)
        assert abs(cb.fx - ca.fx) < 1e-4 and abs(cb.cx - ca.cx) < 1e-6 and abs(cb.cy - ca.cy) < 1e-6


def test_both_layouts_resolve_the_same_settings(pair):
    s = {k: v["settings"] for k, v in pair["results"].items()}
    assert s["nerf"]["layout"] == "nerf" and s["colmap"]["layout"] == "colmap"
    # The set was rendered by Blender 3.4 (Principled v1, box filter): both layouts read its record.
    assert s["nerf"]["brdf"] == "principled" and s["nerf"]["pixel_filter"] == "box 1"
    assert s["nerf"]["env"].startswith("latlong")
    differ = {k: (s["nerf"].get(k), s["colmap"].get(k)) for k in set(s["nerf"]) | set(s["colmap"])
              if k not in INPUT_ENTRIES and s["nerf"].get(k) != s["colmap"].get(k)}
    assert not differ, differ


def test_both_layouts_reach_the_same_albedo(pair):
    m = {k: v["metrics"] for k, v in pair["results"].items()}
    print("albedo PSNR nerf %.3f colmap %.3f dB, NVS %.3f / %.3f dB" % (
        m["nerf"]["albedo_psnr"], m["colmap"]["albedo_psnr"], m["nerf"]["nvs_psnr"], m["colmap"]["nvs_psnr"]))
    assert math.isfinite(m["nerf"]["albedo_psnr"]) and m["nerf"]["albedo_psnr"] > 15.0
    # Same pixels, masks, cameras (to 2.4e-7: the set's 7-digit matrices against COLMAP's exact
    # rotations) and settings: the runs differ only by those round-offs growing through the Monte
    # Carlo run. Measured (seeds 0 / 1 / 2, COLMAP minus NeRF): albedo +0.031 / +0.001 / -0.005 dB,
    # NVS +0.008 / -0.077 / +0.028 dB, where the seeds themselves spread 0.36 dB (24.25-24.60) in
    # albedo. The capture inverted with principled-v2 (before issue 38: the record read for NeRF
    # sets only) measured -0.124 dB albedo at seed 0; 24 SGs would cost ~3 dB (docs/captures.md).
    assert abs(m["nerf"]["albedo_psnr"] - m["colmap"]["albedo_psnr"]) < 0.08, m
    assert abs(m["nerf"]["nvs_psnr"] - m["colmap"]["nvs_psnr"]) < 0.2, m
