"""A known HDRI handed over in the wrong orientation, exposure and colour is lined up from the photos (issue 52).

A tiny Cycles set (the sample object under the studio map, masked photos): its true training
map is turned about the up axis by numpy (a whole number of texel columns), scaled and tinted,
and handed to the optimiser as `env_init`. The alignment (optim/env_align.h) must find the yaw
that undoes the turn (two angles, so a sign error cannot pass), and in "full" mode an exposure that
undoes the scale relative to what it finds for the exact map (masked photos cannot tell the
light's absolute level from the albedo's: docs/known_light.md; the exposure and white balance
from a background the photos see are checked by tests/blender/test_addon_optimize.py); the unturned map must
score clearly worse than the solved yaw, and the exact map must stay at 0 degrees. With the map held fixed, "auto" finds its level by
short inversions at candidate levels, within 10 % of the truth relative to the exact map's and
within a factor 1.5 absolutely. Then the CLI path: `ptir optimize --iters 1` records the
alignment in OUT/settings.json.
"""

import json

import numpy as np
import pytest

from ptir_testing import BLENDER, REPO, needs_blender
from ptir_testing import run_checked as run

pytestmark = needs_blender

EXPOSURE = 2.3
TINT = np.array([1.1, 1.0, 0.85], np.float32)


@pytest.fixture(scope="module")
def tiny_set(tmp_path_factory):
    data = tmp_path_factory.mktemp("align") / "data"
    run([*BLENDER, "-P", REPO / "scripts" / "make_dataset.py", "--", "--out", data, "--res", "40", "--train", "8",
         "--test", "1", "--spp", "32", "--relight-envs", "", "--threads", "2"], timeout=600)
    meta = json.loads((data / "dataset.json").read_text())
    return data, data / meta["envmaps"][meta["train_env"]]


def handed_over(ptir, true_env, folder, yaw_deg, exposure=1.0, tint=(1.0, 1.0, 1.0)):
    """The true map turned so that a World needs rotation_z = yaw (whole columns), scaled and tinted.

    Looked up with rotation_z = r, a direction at u reads the map at u - r / 360 (lights/environment.h),
    so the map M with M(u - r / 360) = T(u) is T rolled by -r / 360 of its width. Returns its path and
    the yaw its whole-column roll stands for."""
    t = ptir.read_image(str(true_env))[:, :, :3]
    cols = int(round(yaw_deg / 360.0 * t.shape[1]))
    m = np.roll(t, -cols, axis=1) * np.float32(exposure) * np.asarray(tint, np.float32)
    path = folder / f"handed_{yaw_deg}_{exposure}.exr"
    ptir.write_image(str(path), np.ascontiguousarray(m, np.float32))
    return path, 360.0 * cols / t.shape[1]


def align(ptir, data, env, mode):
    opt = ptir.Optimizer(str(data), str(data / "oracle" / "gaussians.ply"), iters=0, spp=4, env_init=str(env),
                         fix_env=True, env_align=mode, threads=2)
    return opt.env_alignment


def yaw_error(a, b):
    d = abs(a - b) % 360.0
    return min(d, 360.0 - d)


def test_a_turned_scaled_tinted_map_is_lined_up(ptir, tiny_set, tmp_path):
    data, true_env = tiny_set
    exact = align(ptir, data, true_env, "full")
    print("exact map:", {k: exact[k] for k in ("yaw_deg", "scale", "score", "score_unaligned")})
    assert exact["yaw_deg"] == 0.0  # a map that already fits keeps its orientation
    for turn in (100, 250):
        path, truth = handed_over(ptir, true_env, tmp_path, turn, EXPOSURE, TINT)
        full = align(ptir, data, path, "full")
        relative = np.asarray(full["scale"]) / np.asarray(exact["scale"])
        print(f"turned {truth:.1f} deg: solved {full['yaw_deg']} deg, score {full['score']:.4f} "
              f"(unaligned {full['score_unaligned']:.4f}), scale relative to the exact map's {relative}")
        assert yaw_error(full["yaw_deg"], truth) <= 5.0
        # The exposure undone (relative to what the exact map gets: masked photos fix the level only
        # up to the albedo's, docs/known_light.md), within 10 %; the map's colour is kept.
        assert relative == pytest.approx([1.0 / EXPOSURE] * 3, rel=0.10)
        assert full["scale_from"] == "mean albedo"
        # The map as handed over (0 degrees) explains the photos clearly worse.
        assert full["score_unaligned"] > 1.2 * full["score"]  # measured 1.50 here, 1.29 on the 100-px sample
        assert [0.0, full["score_unaligned"]] in full["candidates"]
    # "yaw" on masked photos: the yaw, and the map's own level.
    path, truth = handed_over(ptir, true_env, tmp_path, 250, EXPOSURE, TINT)
    yaw = align(ptir, data, path, "yaw")
    assert yaw_error(yaw["yaw_deg"], truth) <= 5.0
    assert yaw["scale"] == [1.0, 1.0, 1.0] and yaw["scale_from"] == "none"


def luminance(c):
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


def test_auto_finds_the_level_by_short_inversions(ptir, tiny_set, tmp_path):
    """On masked photos with the map held fixed, "auto" picks the map's level by short inversions at
    candidate levels (the optimiser's search_known_level): the highlights, the bounce light and the
    albedo's bound tell it where a forward fit with the start materials cannot (docs/known_light.md)."""
    data, true_env = tiny_set
    path, truth = handed_over(ptir, true_env, tmp_path, 250, EXPOSURE, TINT)
    exact = align(ptir, data, true_env, "auto")
    auto = align(ptir, data, path, "auto")
    print("exact map: exposure %.3f, handed over: %.3f (yaw %.1f); candidates %s"
          % (exact["exposure"], auto["exposure"], auto["yaw_deg"], auto["level_candidates"]))
    assert auto["scale_from"] == "short inversions" and len(auto["level_candidates"]) >= 3
    assert yaw_error(auto["yaw_deg"], truth) <= 5.0
    # The level undone: relative to what the exact map gets, within 10 % of 1 / 2.3 (measured 0.450
    # for 0.430: the 2.3 and the tint's luminance); the map's colour is kept (one exposure).
    relative = auto["exposure"] / exact["exposure"]
    assert relative == pytest.approx(1.0 / (EXPOSURE * luminance(TINT)), rel=0.10)
    assert auto["scale"][0] == auto["scale"][1] == auto["scale"][2]
    # Against the truth itself: within a factor 1.5 (measured 1.41, and 1.35 for the exact map: short
    # inversions prefer a somewhat brighter light, which cost no albedo PSNR on three sets), where the
    # map as handed over is 2.3 off and the mean-albedo start ("full") 0.79 here.
    absolute = auto["exposure"] * EXPOSURE * luminance(TINT)
    assert 1.0 / 1.5 < absolute < 1.5, absolute


def test_the_cli_records_the_alignment(cli, ptir, tiny_set, tmp_path):
    data, true_env = tiny_set
    path, truth = handed_over(ptir, true_env, tmp_path, 100, EXPOSURE, TINT)
    out = tmp_path / "out"
    r = run([cli, "optimize", "--dataset", data, "--gaussians", data / "oracle" / "gaussians.ply", "--fit-iters", "0",
             "--iters", "1", "--spp", "2", "--env-init", path, "--fix-env", "--threads", "2", "--out", out], timeout=600)
    assert "env-align auto: yaw" in r.stderr
    rec = json.loads((out / "settings.json").read_text())["env_align"]
    assert rec["mode"] == "auto" and yaw_error(rec["yaw_deg"], truth) <= 5.0
    assert len(rec["candidates"]) >= 36 and rec["score"] < rec["score_unaligned"]
    # The map held fixed on masked photos: its level from short inversions, each candidate recorded.
    assert rec["scale_from"] == "short inversions" and len(rec["level_candidates"]) >= 3
    assert rec["level_iterations"] >= 30 and rec["exposure"] == pytest.approx(luminance(rec["scale"]), rel=1e-6)
    # The written map is the aligned one: the true map's brightest column, turned back to its place.
    true_map = ptir.read_image(str(true_env))[:, :, :3]
    written = ptir.read_image(str(out / "env.exr"))[:, :, :3]
    assert np.argmax(written.sum(axis=(0, 2))) == pytest.approx(np.argmax(true_map.sum(axis=(0, 2))), abs=2)
    # Off: the map as given, nothing recorded.
    off = tmp_path / "off"
    run([cli, "optimize", "--dataset", data, "--gaussians", data / "oracle" / "gaussians.ply", "--fit-iters", "0",
         "--iters", "1", "--spp", "2", "--env-init", path, "--fix-env", "--env-align", "off", "--threads", "2",
         "--out", off], timeout=600)
    assert "env_align" not in json.loads((off / "settings.json").read_text())
