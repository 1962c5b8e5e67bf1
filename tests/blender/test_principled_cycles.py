"""Cycles' Principled BSDF (Blender 3.4) against ours, on a scene built and rendered by the test.

tests/blender/principled_compare_scenes.py builds a 5 x 4 grid of Principled spheres
(roughness 0.1 / 0.3 / 0.6 / 0.9 by row; dielectrics with specular 0.2 / 0.5 / 0.8
and tint 0 / 1, a metal, a half-metal with tint) over an Oren-Nayar ground under a
sky-and-sun world, for the distributions GGX and Multiscatter GGX, renders Cycles
references with two seeds (SAMPLES each) and exports the scene with the add-on's
exporter (the path F12 takes). We render the exported scene with the native module
(Principled v1, named in the scene: v2 is the default) at OUR_SPP.

Metrics:
  per sphere and channel, the relative error of the mean linear radiance over the
  sphere's interior pixels (its index-map pixels eroded by one) against the mean of
  the two Cycles renders; the noise floor is the same quantity between the two
  Cycles renders (each half the samples);
  whole-image PSNR on sRGB-encoded, [0, 1]-clipped images.
Bounds (GGX; Multiscatter GGX: 6 % + 3 sigma, see the test): mean relative error
per sphere and channel <= 1 % + 3 sigma, sigma the
Monte Carlo standard error of the comparison, pooled over the row (same
roughness): Cycles' from its seed pair, ours from two seeds. Glossy spheres
(roughness 0.1 and 0.3) reflecting the sun patch are noisy in both renderers
(measured pair floors up to 2.7 %), so the 1 % is only assertable where the
noise allows; rows 0.6 and 0.9 have sigma ~0.1 % and meet 1 % outright. With
ours at 2048 spp every sphere measured within 0.8 % except a roughness-0.1
dielectric at 1.6 % whose own Cycles pair differed by 0.9 %. GGX whole image
>= 36 dB. The same spheres under the simplified Disney model (the paper's) are
far off (asserted > 4 %): the bound can fail.
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

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
SCRIPT = "principled_compare_scenes.py"
BLENDER = shutil.which(os.environ.get("BLENDER", "blender"))
SAMPLES = 256
OUR_SPP = 512
RES = 200

sys.path.insert(0, str(HERE))
sys.path.insert(0, str(REPO / "addon"))
import addon_common as ac  # noqa: E402
from test_cycles_compare import make_environment, psnr as psnr_srgb  # noqa: E402

pytestmark = pytest.mark.skipif(BLENDER is None, reason="blender not installed")


@pytest.fixture(scope="module")
def cycles(ptir):
    with tempfile.TemporaryDirectory(prefix="ptir_principled_") as tmp:
        env = make_environment(ptir, Path(tmp) / "environment.exr")
        info = ac.blender_result(SCRIPT, "PTIR_PRINCIPLED_COMPARE_JSON", "--out-dir", tmp, "--env", env,
                                 "--samples", SAMPLES, "--seeds", 1, 2, "--res", RES, timeout=1800)
        info["dir"] = Path(tmp)
        yield info


def erode(mask):
    m = mask.copy()
    m[1:, :] &= mask[:-1, :]
    m[:-1, :] &= mask[1:, :]
    m[:, 1:] &= mask[:, :-1]
    m[:, :-1] &= mask[:, 1:]
    return m


def sphere_errors(ours, a, b, index, ours2=None):
    """Per sphere: (relative error of mean(ours, ours2) vs mean(a, b), and the relative standard
    error of that difference from the two seed pairs (|a - b| / 2 and |ours - ours2| / 2)), each (3,)."""
    ref = 0.5 * (a + b)
    ours2 = ours if ours2 is None else ours2
    rows = []
    for k in range(1, int(index.max()) + 1):
        m = erode(index == k)
        if m.sum() < 30:
            rows.append(None)
            continue
        mo, mr = 0.5 * (ours[m].mean(0) + ours2[m].mean(0)), ref[m].mean(0)
        se_c = np.abs(a[m].mean(0) - b[m].mean(0)) / 2
        se_o = np.abs(ours[m].mean(0) - ours2[m].mean(0)) / 2
        rows.append((np.abs(mo - mr) / mr, np.sqrt(se_c ** 2 + se_o ** 2) / mr))
    return rows


def render_ours(ptir, cycles, job, model="principled-v1", spp=OUR_SPP, seed=0):
    """The exported scene under `model` (default v1: these are Blender 3.4's spheres; a scene file
    without "brdf" would render v2)."""
    path = cycles["jobs"][job]["scene"]
    with open(path) as f:
        doc = json.load(f)
    doc["brdf"] = model
    path = str(Path(path).with_name("scene_%s.json" % model))
    with open(path, "w") as f:
        json.dump(doc, f)
    return ptir.load_scene(path).render(spp=spp, bounces=2, seed=seed)[..., :3]


@pytest.mark.parametrize("job", ["ggx", "multiggx"])
def test_spheres_match_cycles(ptir, cycles, job):
    d = cycles["dir"] / job
    a, b = np.load(d / "cycles_seed1.npy"), np.load(d / "cycles_seed2.npy")
    index = np.load(d / "index.npy")
    assert index.shape == a.shape[:2] and index.max() == 20
    ours = render_ours(ptir, cycles, job, seed=1)
    ours2 = render_ours(ptir, cycles, job, seed=2)
    rows = sphere_errors(ours, a, b, index, ours2)
    assert all(row is not None for row in rows), "a sphere has too few interior pixels"
    print("\n  %s: per sphere, max over channels of |ours - cycles| / cycles (bound = 1 %% + 3 sigma)" % job)
    failures = []
    # GGX (Blender 3.x's default distribution) is modelled exactly: 1 % + noise. Multiscatter GGX is
    # matched by energy compensation of the height-correlated lobe, not by Cycles' random walk
    # (whose NEE and BSDF-sampled estimators even differ in expectation): measured within
    # 1-2.5 % on dielectrics and up to ~5 % on rough coloured metals, bounded here at 6 %.
    base = 0.01 if job == "ggx" else 0.06
    for r in range(4):
        sig = np.sqrt(np.mean([rows[5 * r + c][1] ** 2 for c in range(5)]))  # pooled over the row
        for c in range(5):
            err = rows[5 * r + c][0]
            bound = base + 3 * sig
            print("    roughness %.1f col %d  %.3f %%  (sigma %.3f %%, bound %.2f %%)"
                  % ((0.1, 0.3, 0.6, 0.9)[r], c, 100 * err.max(), 100 * sig, 100 * bound))
            if err.max() > bound:
                failures.append((r, c, float(err.max()), bound))
            if job == "ggx" and r >= 2 and sig < 0.002 and err.max() > 0.01:
                failures.append((r, c, float(err.max()), 0.01))
    assert not failures, failures
    if job == "ggx":
        p = psnr_srgb(0.5 * (ours + ours2), 0.5 * (a + b))
        p_pair = psnr_srgb(a, b)
        print("  whole image PSNR %.2f dB (Cycles pair %.2f dB)" % (p, p_pair))
        assert p >= 36.0


def splat_twin_scene(cycles, job):
    """The exported scene with every sphere replaced by flat Gaussians (one per triangle, the add-on's
    surface-splat builder) carrying the sphere's true Principled material; the ground stays a mesh."""
    from ptir_blender.io import mesh_ply, surface_splats
    path = Path(cycles["jobs"][job]["scene"])
    doc = json.loads(path.read_text())
    parts, keep = [], []
    for m in doc["meshes"]:
        if not m["name"].startswith("sphere_"):
            keep.append(m)
            continue
        v, t = mesh_ply.read_mesh_ply(str(path.parent / m["file"]))
        g = surface_splats.triangles_to_gaussians(v, t)
        mat = m["material"]
        n = len(g["position"])
        parts.append((g, n, mat))
    g_all = {k: np.concatenate([p[0][k] for p in parts]) for k in ("position", "scale", "rotation", "normal")}
    col = lambda key, width=None: np.concatenate([np.tile(np.asarray(p[2][key], np.float64), (p[1], 1)) if width
                                                  else np.full(p[1], float(p[2][key])) for p in parts])
    surface_splats.write_gaussians_ply(str(path.parent / "twin.ply"), g_all, albedo=col("base_color", 3),
                                       roughness=col("roughness"), metallic=col("metallic"),
                                       specular=col("specular"), specular_tint=col("specular_tint"))
    doc["meshes"] = keep
    doc["gaussians"] = [{"file": "twin.ply"}]
    doc["brdf"] = "principled-v1"  # Blender 3.4's model
    twin = path.parent / "scene_twin.json"
    twin.write_text(json.dumps(doc))
    return twin


def test_splat_twin_matches_cycles_inside_silhouettes(ptir, cycles):
    """Flat-Gaussian twin of the GGX spheres with their true materials, against Cycles' mesh render,
    PSNR over the spheres' pixels at least 2 px inside their silhouettes (>= 33 dB, the issue's bar)."""
    d = cycles["dir"] / "ggx"
    a, b = np.load(d / "cycles_seed1.npy"), np.load(d / "cycles_seed2.npy")
    index = np.load(d / "index.npy")
    inside = erode(erode(index > 0))
    scene = ptir.load_scene(str(splat_twin_scene(cycles, "ggx")))
    ours = scene.render(spp=OUR_SPP, bounces=2, seed=3)[..., :3]
    ref = 0.5 * (a + b)
    mse = float(np.mean((srgb_of(ours[inside]) - srgb_of(ref[inside])) ** 2))
    p = 10 * math.log10(1.0 / max(mse, 1e-20))
    mse_pair = float(np.mean((srgb_of(a[inside]) - srgb_of(b[inside])) ** 2))
    print("\n  splat twin inside the silhouettes: %.2f dB (Cycles pair %.2f dB), %d pixels"
          % (p, 10 * math.log10(1.0 / max(mse_pair, 1e-20)), int(inside.sum())))
    assert p >= 33.0


def srgb_of(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def test_paper_model_is_caught(ptir, cycles):
    """The bound can fail: the simplified Disney model on the same spheres is far outside it."""
    d = cycles["dir"] / "ggx"
    a, b = np.load(d / "cycles_seed1.npy"), np.load(d / "cycles_seed2.npy")
    ours = render_ours(ptir, cycles, "ggx", model="disney-simplified", spp=64)
    rows = sphere_errors(ours, a, b, np.load(d / "index.npy"))
    worst = max(float(r[0].max()) for r in rows if r is not None)
    print("\n  simplified Disney model: worst sphere error %.1f %%" % (100 * worst))
    assert worst > 0.04
