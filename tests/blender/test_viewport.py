"""The live PTIR viewport in a real Blender window under Xvfb (steps in viewport_check.py): Rendered
shading with PTIR (first with the engine missing: said, then rendered once it is back), a splat group's albedo and the lights' power changed (screenshots, colour ratios
measured), the engine process killed mid-render (Blender survives, the next redraw renders again), Film >
Transparent (the world leaves the passes: alpha 0 there, Blender's checkerboard shows; docs/alpha.md), and
F12 through the same process equal to `ptir render` (max difference 0) without a re-export."""

import json
import os
import shutil
import subprocess

import numpy as np
import pytest

import addon_common as ac

pytestmark = pytest.mark.skipif(not ac.have_blender() or shutil.which("xvfb-run") is None,
                                reason="needs blender and xvfb-run")

SAMPLE = ac.REPO / "sample_blends" / "cornell_splats.blend"


def srgb_to_linear(c):
    c = c.astype(np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def shot(path):
    from skimage import io
    img = io.imread(path)[..., :3]
    return srgb_to_linear(img[60:])  # below the 3D view's header


def run_check(tmp_path, *extra):
    env = dict(os.environ, PTIR_CLI=str(ac.CLI), PTIR_TEST_REPO=str(ac.REPO))
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1280x800x24", ac.BLENDER, "--factory-startup", "-noaudio",
           str(SAMPLE), "-P", str(ac.HERE / "viewport_check.py"), "--", str(tmp_path), *extra]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=env)
    assert r.returncode == 0 and "ADDON_CHECK: OK" in r.stdout, ac.output_of(r)
    line = next(l for l in r.stdout.splitlines() if l.startswith("VIEWPORT_CHECK: "))
    return json.loads(line[len("VIEWPORT_CHECK: "):])


def test_live_viewport_edits_kill_and_f12(tmp_path):
    info = run_check(tmp_path)
    steps = info["steps"]
    base, albedo, lights = (shot(steps[k]["screenshot"]) for k in ("base", "albedo", "lights"))
    camera, restarted = shot(steps["camera"]["screenshot"]), shot(steps["restarted"]["screenshot"])
    assert np.std(base) > 0.02, "the Rendered viewport is blank"
    assert "PTIR engine unavailable" in info["missing_message"] and "no_such_dir" in info["missing_message"]

    # Albedo: the splats turn red (their pixels lose green, keep red).
    splat = (albedo[..., 0] - albedo[..., 1]) - (base[..., 0] - base[..., 1]) > 0.1
    g_ratio = albedo[..., 1][splat].mean() / base[..., 1][splat].mean()
    r_ratio = albedo[..., 0][splat].mean() / base[..., 0][splat].mean()
    print("albedo edit: %d splat pixels, green x%.3f, red x%.3f" % (splat.sum(), g_ratio, r_ratio))
    assert splat.sum() > 500
    assert g_ratio < 0.35 and r_ratio > 0.7

    # Lights and world doubled: the same samples, so every unclipped linear value doubles exactly
    # (up to 8-bit rounding).
    ok = (albedo > 0.02) & (albedo < 0.4)
    ratio = lights[ok].sum() / albedo[ok].sum()
    print("light edit: linear ratio %.4f over %d values" % (ratio, ok.sum()))
    assert abs(ratio - 2.0) < 0.04

    # Deltas only: no reload after the first load; an albedo edit of every splat sends the albedo channel
    # alone (12 bytes per splat), straight from the operator.
    assert steps["albedo"]["loads"] == steps["lights"]["loads"] == steps["camera"]["loads"] == 1
    assert "load" not in steps["albedo"]["sent_bytes"] and "load" not in steps["lights"]["sent_bytes"]
    assert 2000 * 12 <= steps["albedo"]["sent_bytes"]["splat_materials"] < 2000 * 12 + 400
    assert steps["lights"]["sent_bytes"]["update"] < 2000
    assert set(steps["camera"]["sent_bytes"]) == {"render"}

    # Moving the splat object: a transform delta (the engine rebuilds its BVH), no re-export.
    move = shot(steps["move"]["screenshot"])
    assert set(steps["move"]["sent_bytes"]) == {"render", "transform_splats"} and steps["move"]["loads"] == 1
    assert (np.abs(move - camera).max(axis=-1) > 0.1).sum() > 500, "the splats did not move on screen"

    # The kill: Blender kept running, said so, and a new engine (a fresh export of the moved object)
    # renders the same picture.
    assert info["pending_when_killed"] and "died (SIGKILL)" in info["death_message"]
    assert steps["restarted"]["engine_pid"] != steps["camera"]["engine_pid"]
    assert np.abs(restarted - move).max() <= 2.0 / 255.0

    # Film > Transparent: the world seen directly leaves the viewport's passes (alpha 0 there, drawn
    # premultiplied over the viewport's background), what covers the pixels stays (alpha 1), no reload.
    film = steps["film"]
    print("film transparent: %.3f of the pixels alpha 0, %.3f alpha 1" % (film["alpha_zero"], film["alpha_one"]))
    # Measured: 0.988 of the pixels alpha 0 (the sky and the ground are the environment), 0.010 alpha 1 (the box).
    assert film["alpha_zero"] > 0.5 and film["alpha_one"] > 0.005 and film["loads"] == steps["restarted"]["loads"]
    transparent = shot(film["screenshot"])
    assert (np.abs(transparent - restarted).max(axis=-1) > 0.05).mean() > 0.05, "the world still shows"

    # F12 through the same process: no re-export, the CLI's image exactly, AOV passes in the compositor.
    f12 = info["f12"]
    assert f12["same_process"] and not f12["reloaded"] and "load" not in f12["sent_bytes"]
    assert {"Depth", "Normal", "Albedo", "Roughness", "Metallic", "Opacity"} <= set(f12["passes"])
    # Depth: the box seen from 3.3 m in front of its open side (surfaces 2.3 to 5.3 m away).
    print("F12 depth pass: %.2f of the pixels hit, median %.3f m, max %.3f m"
          % (f12["depth_hit_fraction"], f12["depth_median"], f12["depth_max"]))
    assert f12["depth_hit_fraction"] > 0.5 and 2.0 < f12["depth_median"] < 5.5 and f12["depth_max"] < 8.0
    out = tmp_path / "cli.exr"
    r = subprocess.run([str(ac.CLI), "render", f12["scene"], "-o", str(out), "--camera", f12["camera"],
                        "--spp", str(f12["spp"]), "--seed", str(f12["seed"]), "--bounces", str(f12["bounces"]), "-q"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    cmp = ac.run_blender("exr_compare.py", f12["exr"], out)
    assert cmp.returncode == 0 and "EXR_DIFF: 0" in cmp.stdout, ac.output_of(cmp)
    for k in ("base", "albedo", "lights", "camera", "move"):
        print("%s: first pixels %.3f s, %s" % (k, steps[k]["first_pixels_s"], steps[k]["sent_bytes"]))
