"""The inversion needs its indirect bounces: on a textured Cycles dataset (noise in
base colour and roughness per polygon, the kind of object the inversion is measured
on) the same run with the bounces cut to direct light only must lose at least 2 dB
of albedo: the albedo then has to make up for the missing bounce light, and bakes it
in (brighter creases, a darker level).

Measured (64 px, 16 training views, 300 iterations x 8 spp, eval 32 spp; seeds 0, 1,
2), with the loss's sRGB curve after its blur (the default): albedo linear (the
inversion issue's protocol) 2 bounces 23.01 / 23.08 / 23.15 dB, direct only 20.65 /
20.66 / 20.69 (a loss of 2.36-2.46 dB); sRGB 26.80 / 26.83 / 26.92 against 24.89 /
24.89 / 24.94 (1.91-1.98 dB); NVS 29.35-29.41 against 28.04-28.08. With the curve
per pixel before the blur (the previous default) the sRGB loss was 2.41-2.49 dB and
the linear 3.0: that loss's own brightening bias had added to the missing bounce's.

The set is made in Blender 3.4 (Principled v1, inverted under v1) and in bpy 4.5 (v2, inverted
under v2: the model the set records). 4.5 / v2, seed 0, at 6a99184+: albedo linear 23.39 against
21.14 dB direct only (2.25 dB), sRGB 27.23 against 25.37 (1.86 dB).
"""

import json
import sys

import pytest

from ptir_testing import REPO
from ptir_testing import run_checked as run

sys.path.insert(0, str(REPO / "tests" / "blender"))
import blenders  # noqa: E402  (the three Blenders: Debian's 3.4, bpy 4.5 / 5.0)


def invert_and_score(cli, data, out, bounces):
    run([cli, "optimize", "--dataset", data, "--gaussians", data / "gaussians.ply", "--spp", "8", "--seed", "0", "-q",
         "--fit-iters", "0", "--iters", "300", "--bounces", bounces, "--out", out], timeout=900)
    run([cli, "eval", "--dataset", data, "--result", out, "--spp", "32", "--sheet-views", "0", "-q"], timeout=300)
    return json.loads((out / "eval" / "metrics.json").read_text())


@pytest.mark.parametrize("blender", blenders.params("3.4", "4.5"))
def test_a_missing_bounce_costs_the_albedo(cli, tmp_path, blender):
    data = tmp_path / "data"
    run(blenders.command(blender, REPO / "scripts" / "make_dataset.py",
                         ["--out", data, "--res", "64", "--train", "16", "--test", "4", "--spp", "32", "--textured",
                          "--threads", "2"]), timeout=600)
    full = invert_and_score(cli, data, tmp_path / "bounces2", 2)
    direct = invert_and_score(cli, data, tmp_path / "bounces0", 0)
    print("Blender %s: albedo linear / sRGB / NVS: 2 bounces %.2f / %.2f / %.2f dB, direct light only %.2f / %.2f / %.2f dB"
          % (blender, full["albedo_psnr_linear"], full["albedo_psnr"], full["nvs_psnr"], direct["albedo_psnr_linear"],
             direct["albedo_psnr"], direct["nvs_psnr"]))
    assert full["albedo_psnr"] > 25.5  # measured 26.80-26.92
    assert direct["albedo_psnr_linear"] < full["albedo_psnr_linear"] - 2.0  # measured 2.36-2.46 dB lower
    assert direct["albedo_psnr"] < full["albedo_psnr"] - 1.5  # measured 1.91-1.98 dB lower
    # measured 1.33-1.37 dB at 71ce42f; 0.75 dB after the release that made the dataset maker run in three
    # Blenders (its ground truth from AOVs, passes from the render's EXR) and added two-sided splats, with the
    # albedo gaps above also ~0.2 dB smaller (2.15 / 1.75 dB): the cause is not isolated yet
    assert direct["nvs_psnr"] < full["nvs_psnr"] - 0.5
