"""A strongly coloured light must not go into the albedo (issue 41, docs/family.md).

The family's test member (bench/family_def.py COLOUR_TEST): a low-poly icosahedron on a plinth with a
NEUTRAL (grey) per-face pattern, lit only by the "coloured" environment (an orange room, orange key,
magenta fill: its mean radiance is about (0.5, 0.24, 0.09) of its red), rendered by Cycles 3.4 at 64^2
(12 training views, 3 test views, 32 spp). `ptir optimize` recovers albedo, roughness and the light
from the images alone at the command's defaults except the budget (150 iterations x 4 spp, the set's
splats as they are: --fit-iters 0), and `ptir eval` reports the per-channel scale s_c = median(gt_c /
ours_c) that aligns our albedo to the truth.

A neutral albedo recovered means the three scales agree: |s_c / mean(s) - 1| <= NEUTRAL_TOL in every
channel. Measured at this setting, seeds 1 / 2 / 3 (docs/family.md, "The colour test"): the largest
deviation is 0.035 / 0.036 / 0.050 with the grey-world prior along the light-albedo balance at its
default weight (--lambda-albedo-grey 0.001), 0.084 / 0.090 / 0.116 without it (0, the model of before:
seed 1's scales 1.126 / 1.044 / 1.228, the light's orange-magenta partly kept in the albedo), and
0.004-0.006 at 0.01. The issue's bar is 10 %, which the model of before passes on two seeds of three at
this small budget; the bound here is 7 %, between the two models' measured ranges with 2 points of margin
on each side, so that the test fails on the model of before.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import blenders

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "bench"))
import family_def  # noqa: E402
import make_family  # noqa: E402

BUILD = Path(os.environ.get("PTIR_BUILD_DIR", REPO / "build")).resolve()
CLI = BUILD / "bin" / "ptir"
NEUTRAL_TOL = 0.07  # measured <= 0.050 with the default prior, >= 0.084 without (seeds 1-3, docstring)

pytestmark = pytest.mark.skipif(not blenders.available("3.4"), reason=blenders.why_missing("3.4"))


def chroma_of(scale):
    mean = sum(scale) / 3.0
    return [s / mean for s in scale]


def test_coloured_light_leaves_a_neutral_albedo(tmp_path):
    data, _, _ = make_family.make(family_def.COLOUR_TEST, tmp_path)
    meta = json.load(open(data / "dataset.json"))
    assert meta["textured"]["neutral"] and meta["train_env"] == "coloured"
    out = tmp_path / "result"
    subprocess.run([str(CLI), "optimize", "--dataset", str(data), "--gaussians", str(data / "gaussians.ply"),
                    "--out", str(out), "--fit-iters", "0", "--iters", "150", "--spp", "4", "--seed", "1", "-q"],
                   check=True)
    subprocess.run([str(CLI), "eval", "--dataset", str(data), "--result", str(out), "--spp", "16",
                    "--sheet-views", "0", "-q"], check=True)
    m = json.load(open(out / "eval" / "metrics.json"))
    chroma = chroma_of(m["albedo_scale"])
    print("per-channel scale %s, against their mean %s, albedo %.2f dB" % (
        m["albedo_scale"], [round(c, 3) for c in chroma], m["albedo_psnr"]))
    assert all(abs(c - 1.0) <= NEUTRAL_TOL for c in chroma), (m["albedo_scale"], chroma)
