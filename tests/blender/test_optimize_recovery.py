"""End-to-end recovery: Cycles renders of known materials -> Gaussians -> `ptir optimize`.

1. tests/blender/make_recovery_dataset.py (in Blender) renders 14 views (80x80,
   64 spp) of an icosphere (albedo (0.70, 0.30, 0.12), roughness 0.25) and a cube
   (albedo (0.15, 0.40, 0.60), roughness 0.65), each one uniform Principled BSDF
   (metallic 0, specular 0.5), under a synthetic sky + ground + sun HDR, and turns
   both meshes into flat Gaussians (one per face, no normals).
2. `ptir optimize` recovers albedo, roughness and a 128x64 environment from the
   images alone (the environment starts at a constant 0.5): 400 iterations, 8 spp,
   2 bounces, seed 1 -- half the paper's 800 iterations, about a minute on 2 cores.
3. Evaluation as docs/method.md §7: the recovered albedo/roughness maps are rendered
   from the training cameras (primary-hit AOVs at pixel centres); a part-ID map
   (the same AOV with one-hot "albedo" per part) keeps the pixels that see one part
   only; albedo is aligned by s_c = median(gt_c / pred_c) over all those pixels;
   then per part the median aligned albedo and median roughness are compared with
   the truth.

Bounds, and why:
* Albedo, per part and channel: |aligned / true - 1| <= 0.15. The residual comes
  from (a) the model mismatch: Cycles' Principled BSDF (Burley diffuse with
  retro-reflection, Smith masking) is not the paper's simplified Disney BRDF
  (Lambert x (1 - F), Schlick-GGX masking with k = alpha/2). Rendering the TRUE
  materials under the TRUE environment with ptir gives 0.95/0.93/0.90 (sphere) and
  0.88/0.90/0.91 (cube) of Cycles' mean RGB: the common part goes into the
  alignment scale, the part-to-part difference (up to ~7 %) does not; (b) the
  albedo/lighting ambiguity of the jointly recovered environment; (c) 200
  iterations at 8 spp (measured: at most 9 %; with the decorrelated adjoint at
  400 iterations, seeds 1-3: at most 9 %, the cube's red). A run that learned nothing would
  fail: a uniform albedo aligned to both parts is off by > 50 % on some channel.
* Roughness of the sphere (truth 0.25, init 0.6): at least a quarter of the way
  from init to truth. Under the paper's simplified Disney BRDF and independent
  random numbers it reached 0.22 here; under the Principled BSDF (the data's own
  model) with stratified samples it reaches ~0.46 in these 200 iterations (0.63
  before the inversion sampled the specular lobe at least half the time): the
  diffuse lobe's roughness-dependent retro-reflection now shares the roughness
  signal with the highlight. With the decorrelated adjoint (the default: the
  loss's gradient from one half of the samples, the replay on the other) the
  sphere reaches 0.58 in 200 iterations and 0.47 / 0.48 / 0.47 in 400 (seeds
  1 / 2 / 3), hence the 400 here. The same-sample adjoint got there faster
  (0.41 at 200, 0.31 at 400) for a biased reason: its step follows the gradient
  of the render's variance too, which sharpens every lobe (tests/native/
  test_decorrelated_adjoint.cpp: +34 standard errors on the roughness gradient
  at the truth), and it took the cube below its truth (0.54 / 0.51 against
  0.65; decorrelated 0.61).
* Roughness of the cube: only that it comes out clearly rougher than the sphere
  (by >= 0.05) and not above the truth + 0.1. Flat faces see the sun's highlight
  in few views, so their roughness is set by the brightness of a broad lobe --
  where the two BRDF models differ most: Schlick-GGX masking keeps 84-91 % of the
  energy of Smith masking at roughness 0.65 for the view angles used, and ptir
  renders the true cube 12 % darker than Cycles in red (its specular-dominated
  channel). Lowering the roughness to ~0.35 brings ptir's render to Cycles'
  (measured: red 0.88 -> 0.975), so the recovered value (~0.37) is the
  model-consistent one, not a failure of the optimiser; the same happens with a
  Lambert + GGX Cycles material and with the true environment held fixed.
"""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import blenders

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("PTIR_BUILD_DIR", REPO / "build")).resolve()
CLI = BUILD / "bin" / "ptir"

ALBEDO_REL_TOL = 0.15
SPHERE_ROUGHNESS_MAX = 0.6 - 0.25 * (0.6 - 0.25)  # a quarter of the way from init to truth
# ROUGHNESS_NOTE: this check runs at PTIR's constant rates with every group learnt from the
# first step. With the default schedules (albedo learnt after the light, rates decaying over
# the second half; README, method notes) the uniform glossy sphere keeps a rougher value in
# 200 iterations (per-Gaussian mean 0.62 vs 0.54 here, same-sample adjoint): its highlight is partly taken by a
# sharper environment while the albedo is held back. Those defaults win on textured objects
# (albedo +2.4 dB, roughness MSE 0.0050 -> 0.0028), which this scene does not have.


@pytest.mark.parametrize("blender", blenders.params("3.4", "4.5"))
def test_recovers_known_materials_from_cycles_renders(ptir, tmp_path, blender):
    """Blender 3.4 renders Principled v1 and the run inverts under v1; bpy 4.5 renders v2 and the run
    inverts under v2 (the model each set records in its "ptir_brdf"); the same bounds hold for both.
    Measured at 6a99184+ (seed 1): worst albedo error 4.1 % (3.4, v1) / 3.3 % (4.5, v2); sphere roughness
    0.421 / 0.427, cube 0.614 / 0.619 (truth 0.25 / 0.65)."""
    assert CLI.exists(), f"no CLI at {CLI}"
    data = tmp_path / "data"
    r = subprocess.run(blenders.command(blender, Path(__file__).with_name("make_recovery_dataset.py"), ["--out", data]),
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    truth = json.loads((data / "truth.json").read_text())["parts"]

    out = tmp_path / "out"
    r = subprocess.run([str(CLI), "optimize", "--dataset", str(data), "--gaussians", str(data / "gaussians.ply"), "--out",
                        str(out), "--iters", "400", "--spp", "8", "--bounces", "2", "--seed", "1", "-q", "--fit-iters", "0",
                        # PTIR's constant rates, everything learnt at once (see ROUGHNESS_NOTE)
                        "--lr-final", "1", "--albedo-warmup", "0"],
                       capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    log = [l.split(",") for l in (out / "log.csv").read_text().splitlines()[1:]]
    first = np.mean([float(l[2]) for l in log[:10]])
    last = np.mean([float(l[2]) for l in log[-10:]])
    assert last < 0.6 * first, (first, last)

    # Recovered maps from the training cameras, and which part each pixel sees.
    field = ptir.load_gaussians(str(out / "gaussians.ply"))
    scene = ptir.Scene(field)
    cameras = ptir.load_dataset(str(data)).cameras
    names = list(truth)
    albedo = field.albedo.copy()
    onehot = np.zeros_like(albedo)
    for k, name in enumerate(names):
        a, b = truth[name]["gaussians"]
        onehot[a:b, k] = 1.0
    A = np.concatenate([scene.render_aov(c, "albedo").reshape(-1, 4) for c in cameras])
    R = np.concatenate([scene.render_aov(c, "roughness").reshape(-1, 2) for c in cameras])
    field.albedo = onehot
    P = np.concatenate([scene.render_aov(c, "albedo").reshape(-1, 4) for c in cameras])
    field.albedo = albedo

    part = np.full(len(A), -1)
    gt = np.zeros((len(A), 3))
    for k, name in enumerate(names):
        sel = (A[:, 3] > 0.5) & (P[:, k] > 0.99)
        part[sel] = k
        gt[sel] = truth[name]["albedo"]
    fg = part >= 0
    assert fg.sum() > 5000
    scale = np.median(gt[fg] / np.maximum(A[fg, :3], 1e-6), axis=0)

    report = {}
    for k, name in enumerate(names):
        sel = part == k
        rec_albedo = np.median(A[sel, :3] * scale, axis=0)
        rec_rough = float(np.median(R[sel, 0]))
        rel = rec_albedo / np.array(truth[name]["albedo"]) - 1.0
        report[name] = (rec_albedo.round(3).tolist(), rel.round(3).tolist(), round(rec_rough, 3))
    print("recovery (albedo aligned, relative error, roughness):", report, "scale", scale.round(3).tolist())

    for name, (rec_albedo, rel, rough) in report.items():
        assert np.all(np.abs(rel) <= ALBEDO_REL_TOL), (name, report)
    sphere_r, cube_r = report["sphere"][2], report["cube"][2]
    assert sphere_r <= SPHERE_ROUGHNESS_MAX, report
    assert cube_r >= sphere_r + 0.05, report
    assert cube_r <= truth["cube"]["roughness"] + 0.1, report
