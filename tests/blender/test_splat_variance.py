"""Per-pixel variance of the splat twin against Cycles on the mesh, at equal spp.

tests/blender/splat_twin_scene.py builds the bundled sample object (Suzanne,
Catmull-Clark level 2, on a box pedestal; Principled materials) under the dataset
maker's "studio" environment, renders it with Cycles SEEDS times at SPP samples
(Box 1 px, no denoising, adaptive sampling or clamping), exports the mesh scene
and writes the object as flat Gaussians with its true materials (one per
polygon, 9408). This test renders the mesh scene and its splat twin SEEDS times
at SPP samples with the native module, and compares the per-pixel variance over
the seeds inside the object's silhouette (coverage 1 in a 5 x 5 neighbourhood;
ratio of the means over those pixels).

Measured (Blender 3.4.1, 128 x 128, 16 spp, 6 seeds; 2 shared cores):
                                    splat/Cycles  mesh/Cycles  splat/mesh
  independent uniforms (before)         4.44          4.56        0.97
  stratified (math/path_sampler.h)      1.50          1.51        0.99
  and at 64 spp: before 6.96 / 6.93, after 1.49 / 1.57; at 1 spp (no stratification
  possible) both samplers give 1.50: the remaining factor is the estimator itself,
  the same for the mesh twin -- mostly the BRDF's fixed 50/50 choice between its
  diffuse and specular lobes: with a specular probability of 0.25 (an experiment
  in material/disney_brdf.h, not committed) splat/Cycles is 1.07 at 16 spp.
The splat twin adds no variance of its own: splat/mesh is 0.95-1.03 here and on
the glossy sphere of test_cycles_compare.py (environment only, or a point light),
and dark outliers relative to the 3 x 3 median are no more frequent than on the mesh.

Bounds: splat/Cycles <= 1.65 (the measured 1.50 plus the spread of an 8-seed
estimate, about +-5 %; independent uniforms give 4.4, so a sampler regression
fails), splat/mesh <= 1.15 (a splat-specific noise source, e.g. shadow rays
occluded by the interaction's own neighbours, would raise it).
Runtime: about 1 minute.
"""

import glob
import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

import addon_common as ac

SCRIPT = "splat_twin_scene.py"
BLENDER = shutil.which(os.environ.get("BLENDER", "blender"))
RES, SPP, SEEDS = 128, 16, 8

pytestmark = pytest.mark.skipif(BLENDER is None, reason="blender not installed")


@pytest.fixture(scope="module")
def twin():
    with tempfile.TemporaryDirectory(prefix="ptir_splat_twin_") as tmp:
        info = ac.blender_result(SCRIPT, "PTIR_SPLAT_TWIN_JSON", "--out-dir", tmp, "--res", RES, "--samples", SPP,
                                 "--seeds", *range(1, SEEDS + 1), timeout=900)
        info["dir"] = Path(tmp)
        yield info


def interior(coverage, r=2):
    """Pixels whose (2r+1)^2 neighbourhood is fully covered."""
    m = coverage > 0.999
    inner = m.copy()
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            inner &= np.roll(np.roll(m, dy, 0), dx, 1)
    return inner


def test_splat_twin_variance_matches_cycles(ptir, twin):
    d = twin["dir"]
    export = Path(twin["scene"]).parent
    doc = json.loads((export / "scene.json").read_text())
    assert {m["name"] for m in doc["meshes"]} == {"pedestal_0", "pedestal_1", "head", "eye_1", "eye_2"}
    sdoc = dict(doc, meshes=[], gaussians=[{"file": str(d / "gaussians.ply")}])
    mesh = ptir.scene_from_dict(doc, str(export))
    splat = ptir.scene_from_dict(sdoc, str(export))
    assert len(splat.gaussians) == twin["gaussians"] > 9000

    cyc = np.stack([np.load(f) for f in sorted(glob.glob(str(d / "cycles_seed*.npy")))])
    assert cyc.shape == (SEEDS, RES, RES, 3)
    ours_splat = np.stack([splat.render(spp=SPP, seed=100 + s)[..., :3] for s in range(SEEDS)])
    ours_mesh = np.stack([mesh.render(spp=SPP, seed=100 + s)[..., :3] for s in range(SEEDS)])
    inner = interior(splat.render_aov(splat.cameras[0], "opacity", spp=1)[..., -1])
    assert inner.sum() > 800, "test design: the silhouette must hold enough pixels"

    def var(x):
        return float(x.var(0, ddof=1).mean(-1)[inner].mean())

    v_cyc, v_splat, v_mesh = var(cyc), var(ours_splat), var(ours_mesh)
    means = [float(x.mean(0)[inner].mean()) for x in (cyc, ours_splat, ours_mesh)]
    print("\ninside %d px: mean Cycles %.4f splat %.4f mesh %.4f | variance splat/Cycles %.3f, mesh/Cycles %.3f, "
          "splat/mesh %.3f" % (inner.sum(), *means, v_splat / v_cyc, v_mesh / v_cyc, v_splat / v_mesh))
    # Same image on average (the BRDF models differ by a few per cent; the Gaussians reproduce the mesh).
    assert abs(means[1] / means[2] - 1.0) < 0.03
    assert v_splat / v_cyc <= 1.65, "splat twin: per-pixel variance %.2fx Cycles'" % (v_splat / v_cyc)
    assert v_splat / v_mesh <= 1.15, "splat twin: per-pixel variance %.2fx the mesh twin's" % (v_splat / v_mesh)
