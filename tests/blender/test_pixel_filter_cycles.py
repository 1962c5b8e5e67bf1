"""Blackman-Harris pixel filter against Cycles on a silhouette edge.

cycles_compare_scenes.py builds the glossy_m0 scene (a sphere on a plane under a
lat-long environment) with Cycles' pixel filter set to Blender's default,
Blackman-Harris 1.5 px, renders it twice (SAMPLES spp, seeds 1 and 2) and exports
it; the exporter records the film's filter in the scene file. We render the
exported scene with that filter, with the 1-px box (the earlier uniform jitter)
and with Blackman-Harris of half the width (the window spanning +-0.75 px, as if
Cycles' width were the full window), and compare each with the mean of the two
Cycles renders by PSNR (sRGB, clipped) over the band of pixels within 1 px of the
sphere's silhouette (where the filter decides the values).

Measured (Blender 3.4.1, 128 x 128, Cycles 2 x 256 spp, ours 256 spp): edge-band
PSNR Blackman-Harris 1.5 39.3 dB, box 1 px 36.9 dB, Blackman-Harris 0.75 33.0 dB;
the Cycles pair against each other 35.6 dB (its noise floor), whole image 41.9 vs
41.2 dB. Bounds: the matching filter beats each of the others by >= 1.2 dB (half
the measured 2.4 dB gap to the box; the gaps are noise-limited, the Cycles mean
itself carries the pair's noise).
Runtime: about 1.5 minutes.
"""

import json
import math
import os
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

SCRIPT = "cycles_compare_scenes.py"
BLENDER = shutil.which(os.environ.get("BLENDER", "blender"))
SAMPLES, OUR_SPP, RES = 256, 256, 128

sys.path.insert(0, str(Path(__file__).resolve().parent))
import addon_common as ac  # noqa: E402
from test_cycles_compare import make_environment, srgb  # noqa: E402

pytestmark = pytest.mark.skipif(BLENDER is None, reason="blender not installed")


@pytest.fixture(scope="module")
def cycles_bh(ptir):
    with tempfile.TemporaryDirectory(prefix="ptir_filter_") as tmp:
        env = make_environment(ptir, Path(tmp) / "environment.exr")
        info = ac.blender_result(SCRIPT, "PTIR_CYCLES_COMPARE_JSON",
                                 "--out-dir", tmp, "--env", env, "--samples", SAMPLES, "--seeds", 1, 2,
                                 "--res", RES, "--jobs", "glossy_m0", "--pixel-filter", "BLACKMAN_HARRIS",
                                 "--filter-width", 1.5, timeout=900)["jobs"]["glossy_m0"]
        info["dir"] = Path(tmp) / "glossy_m0"
        yield info


def edge_band(ptir, doc, export):
    """Pixels within 1 px of the sphere's silhouette (its box-filtered coverage strictly inside (0, 1))."""
    odoc = dict(doc, meshes=[m for m in doc["meshes"] if m["name"] == "object"])
    odoc.pop("environment", None)
    only = ptir.scene_from_dict(odoc, str(export))
    cov = only.render_aov(only.cameras[0], "opacity", spp=64, pixel_filter="box", filter_width=1.0)[..., -1]
    edge = (cov > 0.01) & (cov < 0.99)
    band = edge.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            band |= np.roll(np.roll(edge, dy, 0), dx, 1)
    return band


def psnr(a, b, mask):
    mse = float(np.mean((srgb(a)[mask] - srgb(b)[mask]) ** 2))
    return 10.0 * math.log10(1.0 / max(mse, 1e-20))


def test_blackman_harris_matches_cycles_on_edges(ptir, cycles_bh):
    export = Path(cycles_bh["scene"]).parent
    doc = json.loads((export / "scene.json").read_text())
    assert doc["integrator"]["pixel_filter"] == "blackman_harris" and doc["integrator"]["filter_width"] == 1.5
    scene = ptir.scene_from_dict(doc, str(export))
    a = np.load(cycles_bh["dir"] / "cycles_seed1.npy")
    b = np.load(cycles_bh["dir"] / "cycles_seed2.npy")
    ref = 0.5 * (a + b)
    band = edge_band(ptir, doc, export)
    assert band.sum() > 400, "test design: the silhouette band must hold enough pixels"
    ours = {
        "blackman_harris 1.5": scene.render(spp=OUR_SPP, seed=3),
        "box 1": scene.render(spp=OUR_SPP, seed=3, pixel_filter="box", filter_width=1.0),
        "blackman_harris 0.75": scene.render(spp=OUR_SPP, seed=3, filter_width=0.75),
    }
    p = {k: psnr(v[..., :3], ref, band) for k, v in ours.items()}
    print("\nedge band (%d px) PSNR vs Cycles (Blackman-Harris 1.5): %s | Cycles pair %.2f dB"
          % (band.sum(), ", ".join("%s %.2f dB" % kv for kv in p.items()), psnr(a, b, band)))
    assert p["blackman_harris 1.5"] >= p["box 1"] + 1.2
    assert p["blackman_harris 1.5"] >= p["blackman_harris 0.75"] + 1.2
