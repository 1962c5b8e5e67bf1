"""The PTIR render engine (F12 / bpy.ops.render.render in blender -b); checks in addon_render_check.py.

1. The sample .blend (sample_blends/cornell_splats.blend: mesh walls, two area lights, an environment
   map, a splat object) renders through the engine, and its image is the CLI's image of the same
   exported scene, pixel for pixel (and the native module's, in-process); a material edit on the
   splats shows in the next render, in the splats and in the light they bounce.

2. A mesh-only Cornell box (Diffuse BSDF walls and boxes, a 0.5 m square area light of 20 W, black
   world, 64 x 64, 128 spp, 3 bounces) rendered by PTIR agrees with Cycles (two seeds each):
       E_mean = |sum clip(ptir) - sum clip(cycles)| / sum clip(cycles)      <= 3 %
       E_L1   = sum |B(clip ptir) - B(clip cycles)| / sum B(clip cycles)    <= 5 %
   with clip(x) = min(x, 1) (the directly seen light, identical in both, does not dominate) and B the
   8 x 8-pixel box average (a per-region relative error that pixel noise does not swamp).
   Why these bounds (measured here): the two Cycles seeds differ by E_mean 0.25 %, E_L1 0.7 %, ours by
   0.1 % and 1.0 % (the noise floor). The rest is the material model: Blender's Diffuse BSDF is
   Lambert, the engine's BRDF at roughness 1 / metallic 0 is PTIR's simplified Disney (diffuse
   (1 - F) a / pi plus a GGX lobe with F0 = 0.04), whose directional albedo for the white walls is 1-2 %
   below Lambert's (0.713-0.723 for 0.73) and whose specular lobe lifts dark channels at grazing angles;
   Cycles also lets rays pass through the area light (about 0.8 %, see test_cycles_compare.py). Measured:
   E_mean 1.75 %, E_L1 3.3 % (3 bounces); 0.6 % and 2.4 % with direct light only. The bounds sit
   above that gap and well below what a broken bridge produces: a wrong light unit (pi/4: 21 %), sRGB
   instead of linear colours (> 30 %), a mirrored or mis-aimed camera, or a wrong field of view (E_L1
   far above 10 %).
3. Spheres and a ground with new Principled BSDF materials of each Blender (v1 in 3.4, v2 in 4.5 / 5.0)
   rendered through the add-on against that Blender's Cycles: whole-image PSNR >= 36 dB.
Each test runs in 3.4, and in bpy 4.5 / 5.0 once the engine has principled-v2 (blenders.v2_needs()).
"""

import json

import numpy as np
import pytest

import addon_common as ac
import blenders

pytestmark = pytest.mark.skipif(not ac.have_blender(), reason="blender not installed")

SAMPLE = ac.REPO / "sample_blends" / "cornell_splats.blend"


def _stats(result, key):
    line = next(l for l in result.stdout.splitlines() if l.startswith(key + ": "))
    return json.loads(line[len(key) + 2:])


@pytest.mark.parametrize("blender", blenders.params(needs=blenders.v2_needs()))
def test_engine_renders_sample_blend_like_the_cli(blender, tmp_path):
    assert SAMPLE.exists(), "missing %s (run sample_blends/make_cornell_splats.py)" % SAMPLE
    r = ac.run_blender("addon_render_check.py", "sample", tmp_path, blend=SAMPLE, blender=blender)
    assert r.returncode == 0 and "ADDON_CHECK: OK" in r.stdout, ac.output_of(r)
    stats = _stats(r, "RENDER_STATS")
    print("sample render: %s" % stats)
    assert stats["engine_vs_cli_max_abs"] == 0.0


@pytest.mark.parametrize("blender", blenders.params(needs=blenders.v2_needs()))
def test_render_break_stops_the_engine_process(blender, tmp_path):
    """Esc sets Blender's break flag; the engine then ends its ptir process and returns (in blender -b
    the flag is set by Ctrl-C, which the check sends to itself)."""
    r = ac.run_blender("addon_render_check.py", "cancel", tmp_path, blend=SAMPLE, blender=blender)
    assert r.returncode == 0 and "ADDON_CHECK: OK" in r.stdout, ac.output_of(r)
    assert _stats(r, "CANCEL_STATS")["seconds"] < 60


def _clip(a):
    return np.minimum(a, 1.0)


def _blocks(a, b=8):
    h, w, _ = a.shape
    return a.reshape(h // b, b, w // b, b, 3).mean(axis=(1, 3))


def e_mean(x, y):
    return abs(_clip(x).sum() - _clip(y).sum()) / _clip(y).sum()


def e_l1(x, y):
    bx, by = _blocks(_clip(x)), _blocks(_clip(y))
    return np.abs(bx - by).sum() / by.sum()


@pytest.mark.parametrize("blender", blenders.params(needs=blenders.v2_needs()))
def test_mesh_scene_agrees_with_cycles(blender, tmp_path):
    r = ac.run_blender("addon_render_check.py", "cycles", tmp_path, 64, 128, 3, blender=blender)
    assert r.returncode == 0 and "ADDON_CHECK: OK" in r.stdout, ac.output_of(r)
    cyc = [np.load(tmp_path / ("cycles_%d.npy" % i)) for i in range(2)]
    ours = [np.load(tmp_path / ("ptir_%d.npy" % i)) for i in range(2)]
    c, p = (cyc[0] + cyc[1]) / 2, (ours[0] + ours[1]) / 2
    m, l1 = e_mean(p, c), e_l1(p, c)
    floor_c, floor_p = e_l1(cyc[0], cyc[1]), e_l1(ours[0], ours[1])
    print("PTIR vs Cycles: E_mean %.4f, E_L1 %.4f (noise floor E_L1: Cycles %.4f, PTIR %.4f)"
          % (m, l1, floor_c, floor_p))
    assert floor_c < 0.02 and floor_p < 0.02, "test design: the renders must be far less noisy than the bound"
    assert m <= 0.03
    assert l1 <= 0.05
    # the image is lit and the light is seen directly in both
    assert c.max() > 10.0 and p.max() > 10.0


def _srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def psnr(x, y):
    return 10.0 * np.log10(1.0 / np.mean((_srgb(x) - _srgb(y)) ** 2))


@pytest.mark.parametrize("blender", blenders.params(needs=blenders.v2_needs()))
def test_default_principled_meshes_agree_with_this_blenders_cycles(blender, tmp_path):
    """Flat-shaded spheres and a ground with new Principled BSDF materials (only Base Color set: v1 in
    3.4, v2 with Multiscatter GGX in 4.5 / 5.0) under a sky colour and a sun, rendered through the add-on
    by the PTIR engine against the same Blender's Cycles (64 x 64, 3 bounces, 2 seeds x 128 spp each):
    whole-image PSNR (sRGB, clipped) >= 36 dB, the issue's bound. Measured in 3.4: 47.6 dB (the Cycles
    pair 48.2 dB). The bound can fail: the v1 model against Cycles 4.5 / 5.0 (the add-on's export forced
    to v1) measured 32.0 dB, the image 7 % too bright."""
    r = ac.run_blender("addon_render_check.py", "principled", tmp_path, 64, 128, 3, blender=blender)
    assert r.returncode == 0 and "ADDON_CHECK: OK" in r.stdout, ac.output_of(r)
    cyc = [np.load(tmp_path / ("cycles_%d.npy" % i)) for i in range(2)]
    ours = [np.load(tmp_path / ("ptir_%d.npy" % i)) for i in range(2)]
    p, floor = psnr((ours[0] + ours[1]) / 2, (cyc[0] + cyc[1]) / 2), psnr(cyc[0], cyc[1])
    print("Blender %s: PTIR vs Cycles %.2f dB (Cycles seed pair %.2f dB)" % (blender, p, floor))
    assert floor > 40.0, "test design: the Cycles renders must be far less noisy than the bound"
    assert p >= 36.0
