"""Our path tracer against Cycles (Blender 3.4), on scenes built and rendered by the test.

tests/blender/cycles_compare_scenes.py builds each scene in Blender, renders the
Cycles reference twice (seeds 1 and 2, SAMPLES each) and exports the scene with
the add-on's scene_export; this test renders the exported scene with the native
module and compares.

Scenes (see cycles_compare_scenes.py for every Cycles setting):
  cornell    mesh-only Cornell box, rectangular area light under the ceiling, bounces 3
  glossy_m0  icosphere (20480 flat faces), roughness 0.3, metallic 0, on a plane,
             lat-long environment only (sky gradient + sun patch), bounces 2
  glossy_m1  the same, metallic 1
  gaussians  glossy_m0/m1 with the sphere replaced by 20480 flat surface Gaussians
             (addon/ptir_blender/io/surface_splats.py), compared with the mesh
             scene's Cycles reference
Materials match our simplified Disney BRDF's directional albedo exactly
(tests/blender/disney_match.py): Cycles has no node for it.

Metrics (ours at OUR_SPP vs the mean of the two Cycles renders, 2 x SAMPLES spp):
  E_mean = |sum clip(ours) - sum clip(cycles)| / sum clip(cycles)
  E_L1   = sum |B(clip ours) - B(clip cycles)| / sum B(clip cycles)
  over all pixels and RGB channels; clip(x) = min(x, 1) keeps the directly seen
  light (radiance 33 in both renderers, identical) from dominating the sums, and
  B is the 8 x 8-pixel box average, which makes E_L1 a per-region relative error
  that per-pixel noise does not swamp. PSNR on sRGB-encoded images clipped to [0, 1].

Bounds and their justification (measured on this machine, Blender 3.4.1, 128 x 128):
  E_mean <= 2 % and E_L1 <= 2 % for cornell and glossy. Noise floor: the two
  Cycles renders against each other (256 spp each) give E_mean 0.06 % and E_L1
  0.37-0.46 %; ours (512 spp) against their mean (512 spp) carries about 0.7x that
  noise. Measured: glossy_m0 E_mean 0.05 %, E_L1 0.34 %; glossy_m1 0.06 %, 0.35 %
  (at the noise floor); cornell E_mean 0.96 %, E_L1 1.08 % -- not noise: Cycles
  lets rays pass THROUGH lights (a BSDF ray hitting the area light continues to
  the ceiling 2 cm behind it), our integrator ends the path at the light; with an
  opening in the ceiling above the light (job cornell_hole, PTIR_CYCLES_FULL=1)
  the gap drops to E_mean 0.26 %, E_L1 0.65 %. The per-channel residue left there
  is in the dark channels of the coloured walls (G, B of the red wall: -3 to -5 %),
  where our BRDF's 4 % specular lobe is a large share of the reflectance and its
  shape in wi (which the matched material cannot copy) matters.
  2 % is 4x the noise floor and 2x the known light-transparency gap, and far below
  the errors it must catch: one bounce fewer in the Cornell box is 6.0 %, a wrong
  area-light unit (pi/4) 21 %.
  PSNR >= 32 dB for the Gaussian sphere (ours at 256 spp): the Cycles pair gives
  the noise floor (pair PSNR 37.6 dB for m0, 36.3 dB for m1); measured 39.0 dB (m0; 42.0 dB since
  the stratified samples of math/path_sampler.h)
  and 36.5 dB (m1, PTIR_CYCLES_FULL=1) -- at the noise level, i.e. the 20480 flat
  Gaussians reproduce the sphere (E_mean 0.04 %). The test requires the pair to reach 30 dB so that a pass
  means the Gaussian surface, not luck in the noise, explains the image.
Runtime: about 3-4 minutes on 2 shared cores (Cycles 6 renders, ours 4).
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

import addon_common as ac

REPO = Path(__file__).resolve().parents[2]
SCRIPT = "cycles_compare_scenes.py"
BLENDER = shutil.which(os.environ.get("BLENDER", "blender"))
SAMPLES = 256      # Cycles, per seed (two seeds)
OUR_SPP = 512
OUR_SPP_GAUSSIANS = 256  # Gaussians trace ~5x slower than triangles; the PSNR noise floor stays > 36 dB
RES = 128
FULL = os.environ.get("PTIR_CYCLES_FULL", "") not in ("", "0")
JOBS = ["cornell", "glossy_m0", "glossy_m1"] + (["cornell_hole"] if FULL else [])

sys.path.insert(0, str(REPO / "addon"))

pytestmark = pytest.mark.skipif(BLENDER is None, reason="blender not installed")


def make_environment(ptir, path, width=128, height=64):
    """Sky gradient, dark ground and a sun patch (8 degrees radius, radiance 25), linear EXR.

    Texel centres map to directions with our (= Cycles') equirectangular convention:
    u = 0.5 - atan2(y, x) / (2 pi), v = 0.5 + asin(z) / pi, row 0 = top (v = 1).
    """
    u, t = np.meshgrid((np.arange(width) + 0.5) / width, (np.arange(height) + 0.5) / height)
    phi = (0.5 - u) * 2.0 * math.pi
    elev = (0.5 - t) * math.pi
    d = np.stack([np.cos(elev) * np.cos(phi), np.cos(elev) * np.sin(phi), np.sin(elev)], -1)
    up = np.clip(d[..., 2:3], 0.0, 1.0)
    sky = np.array([0.35, 0.55, 1.0]) * (0.25 + 0.75 * (1.0 - up) ** 2)
    img = np.where(d[..., 2:3] >= 0.0, sky, np.array([0.12, 0.10, 0.08]))
    az, el = math.radians(40.0), math.radians(35.0)
    sun = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    img[d @ sun > math.cos(math.radians(8.0))] = np.array([25.0, 23.0, 19.0])
    ptir.write_image(str(path), img.astype(np.float32))
    return path


@pytest.fixture(scope="module")
def cycles(ptir):
    with tempfile.TemporaryDirectory(prefix="ptir_cycles_compare_") as tmp:
        env = make_environment(ptir, Path(tmp) / "environment.exr")
        info = ac.blender_result(SCRIPT, "PTIR_CYCLES_COMPARE_JSON", "--out-dir", tmp, "--env", env,
                                 "--samples", SAMPLES, "--seeds", 1, 2, "--res", RES, "--jobs", *JOBS, timeout=1200)
        info["dir"] = Path(tmp)
        yield info


def references(cycles, job):
    a = np.load(cycles["dir"] / job / "cycles_seed1.npy")
    b = np.load(cycles["dir"] / job / "cycles_seed2.npy")
    return a, b, 0.5 * (a + b)


def blocks(img, b=8):
    h, w, c = img.shape
    return img.reshape(h // b, b, w // b, b, c).mean(axis=(1, 3))


def relative_errors(ours, ref):
    o, r = np.minimum(ours, 1.0), np.minimum(ref, 1.0)
    e_mean = abs(float(o.sum()) - float(r.sum())) / float(r.sum())
    bo, br = blocks(o), blocks(r)
    e_l1 = float(np.abs(bo - br).sum()) / float(br.sum())
    return e_mean, e_l1


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def psnr(a, b):
    mse = float(np.mean((srgb(a) - srgb(b)) ** 2))
    return 10.0 * math.log10(1.0 / max(mse, 1e-20))


def render_ours(ptir, scene, seed, spp=OUR_SPP):
    img = scene.render(spp=spp, seed=seed)
    assert img.shape == (RES, RES, 4)
    assert np.all(np.isfinite(img))
    return img[..., :3]


@pytest.mark.parametrize("job", JOBS)
def test_mesh_scene_matches_cycles(ptir, cycles, job):
    a, b, ref = references(cycles, job)
    scene = ptir.load_scene(cycles["jobs"][job]["scene"])
    assert scene.integrator["bounces"] == cycles["jobs"][job]["bounces"]
    ours = render_ours(ptir, scene, seed=11)
    e_mean, e_l1 = relative_errors(ours, ref)
    n_mean, n_l1 = relative_errors(a, b)
    print("\n%s: ours vs Cycles E_mean %.3f %%, E_L1 %.3f %% | Cycles vs Cycles (noise floor) E_mean %.3f %%, "
          "E_L1 %.3f %% | Cycles %.1f s + %.1f s, ours %.1f s"
          % (job, 100 * e_mean, 100 * e_l1, 100 * n_mean, 100 * n_l1, *cycles["jobs"][job]["cycles_seconds"],
             scene.last_render_stats["seconds"]))
    assert n_l1 < 0.01, "test design: the Cycles noise floor must stay well below the 2 % bound"
    assert e_mean <= 0.02, "%s: mean relative error %.2f %% > 2 %%" % (job, 100 * e_mean)
    assert e_l1 <= 0.02, "%s: block relative L1 error %.2f %% > 2 %%" % (job, 100 * e_l1)


def gaussian_scene(ptir, cycles, job, tmp_path):
    """The exported glossy scene with the sphere mesh replaced by flat surface Gaussians."""
    from ptir_blender.io import mesh_ply, surface_splats
    export = Path(cycles["jobs"][job]["scene"]).parent
    doc = json.loads((export / "scene.json").read_text())
    obj = next(m for m in doc["meshes"] if m["name"] == "object")
    v, t = mesh_ply.read_mesh_ply(str(export / obj["file"]))
    g = surface_splats.triangles_to_gaussians(v, t)
    mat = obj["material"]
    ply = tmp_path / "object_gaussians.ply"
    surface_splats.write_gaussians_ply(str(ply), g, albedo=mat["base_color"], roughness=mat["roughness"],
                                       metallic=mat["metallic"])
    doc["meshes"] = [m for m in doc["meshes"] if m["name"] != "object"]
    doc["gaussians"] = [{"file": str(ply)}]
    return ptir.scene_from_dict(doc, str(export)), len(t)


@pytest.mark.parametrize("job", ["glossy_m0"] + (["glossy_m1"] if FULL else []))
def test_gaussian_sphere_matches_cycles(ptir, cycles, job, tmp_path):
    a, b, ref = references(cycles, job)
    scene, faces = gaussian_scene(ptir, cycles, job, tmp_path)
    assert len(scene.gaussians) == faces >= 20000
    ours = render_ours(ptir, scene, seed=13, spp=OUR_SPP_GAUSSIANS)
    p = psnr(ours, ref)
    floor = psnr(a, b)
    e_mean, e_l1 = relative_errors(ours, ref)
    print("\n%s as Gaussians: PSNR %.2f dB (Cycles pair noise floor %.2f dB), E_mean %.3f %%, E_L1 %.3f %%, ours %.1f s"
          % (job, p, floor, 100 * e_mean, 100 * e_l1, scene.last_render_stats["seconds"]))
    assert floor >= 30.0, "test design: Cycles references too noisy to judge a 32 dB bound"
    assert p >= 32.0, "%s with Gaussians: PSNR %.2f dB < 32 dB" % (job, p)
