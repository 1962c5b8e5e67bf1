"""`ptir optimize --gaussians IN.ply` without --dataset: the inversion on targets rendered from the
splats' own radiance (docs/relightable.md).

The capture: the optimiser tests' sphere (ptir_testing.sphere_scene: warm albedo on top, cool below,
roughness 0.25 for highlights, a sky with a sun) rendered by PTIR as 16 photos of 40 x 40, and 4 test
views with their true albedo. `ptir fit` learns the splats' SH radiance (degree 3) from the photos:
that fitted PLY is what a capture app exports. Then the PLY alone goes through the command, and
`ptir eval` scores it against the test views (albedo PSNR, per-channel scale as always).

The test that can fail: the same PLY with a wrong SH basis sign (the odd bands negated: the colour
seen from d is the one the capture saw from -d), or with the virtual cameras inside the object, must
score worse than the right run (bounds from measured values, at the asserts; fixture + 3 runs + 3
evaluations: 72 s of the file's 87 s on 2 cores at load 12).

The PLY layouts other tools write (INRIA SH degree 3, Mip-Splatting's DC only with its 3D filter,
SuperSplat compressed, 2DGS surfels; tests/python/splat_layouts.py), made from the same fitted splats, go through
the command at a quick setting and give finite albedos in [0, 1] that follow the sphere's two
colours (about 4 s each; the whole file 87 s on 2 cores at load 12).
"""

import json
import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

from blender_kit import look_at
from ptir_testing import quat_z_to, sphere_scene, write_splat_ply
import splat_layouts

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
                ptir.write_image(str(folder / "roughness.exr"), scene.render_aov(scene.cameras[i], "roughness", spp=8))
    # The PLY to fit: the sphere's splats with SH degree 3 (zero rest) to learn into.
    pos = np.array(p, np.float64)
    g = root / "input.ply"
    spacing = math.sqrt(4 * math.pi / len(pos))
    write_splat_ply(g, pos, (0.7 * spacing, 0.7 * spacing, 1e-3 * spacing), quat=quat_z_to(pos),
                    colour=(0.5, 0.5, 0.5), sh_rest=45)
    # 2000 iterations: at 300 the SH had hardly left the grey start (DC colour (0.61, 0.59, 0.54) on the warm
    # top, whose photos show (0.89, 0.68, 0.58) at 2000), so the PLY carried almost nothing to recover.
    run([cli, "fit", "--dataset", data, "--gaussians", g, "--out", root / "fit", "--iters", "2000", "-q",
         "--threads", "2"])
    return {"root": root, "data": data, "fitted": root / "fit" / "gaussians.ply"}


def relightable(cli, ply, out, *extra):
    return run([cli, "optimize", "--gaussians", ply, "--out", out, "--iters", "300", "--spp", "4", "--crop", "0",
                "--orbit-views", "16", "--orbit-size", "40", "--env-size", "16x8", "--threads", "2", *extra])


def scores(cli, data, out):
    run([cli, "eval", "--dataset", data, "--result", out, "--spp", "8", "--aov-spp", "4", "--sheet-views", "0",
         "--bounces", "2", "-q"])
    m = json.loads((out / "eval" / "metrics.json").read_text())
    return {k: m[k] for k in ("albedo_psnr", "nvs_psnr", "roughness_mse")}


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
    got = {k: scores(cli, data, tmp_path / k) for k in ("good", "sign", "inside")}
    print("scores:", got)
    good, sign, inside = got["good"], got["sign"], got["inside"]
    # Measured (300 iterations, 2 threads): albedo PSNR good 19.46, wrong sign 18.83, inside 16.19 dB; NVS PSNR
    # 25.38, 23.78, 22.15 dB; roughness MSE 0.048, 0.064, 0.072. The photo-based inversion from the same fitted
    # PLY and budget: albedo 19.73 dB. Cameras inside see the walls' backs, lit by nothing (the closed sphere
    # shuts the sky out): the albedo saturates and loses the top/bottom colours, -3.3 dB; the 2 dB.
    assert good["albedo_psnr"] - inside["albedo_psnr"] >= 2.0, got
    # A wrong sign moves only the view-dependent part, which this capture's albedo hardly needs: with every
    # f_rest zeroed (no view dependence at all) the albedo lost 0.45 dB, the sign 0.63 dB (docs/relightable.md),
    # so 2 dB of albedo is out of a sign's reach. It costs what view dependence drives: the radiance under the
    # capture's light from new views (NVS, -1.60 dB; zeroed f_rest -1.13) and the roughness (MSE x1.33; zeroed
    # x1.29). Bounds: half the measured drops.
    assert good["albedo_psnr"] - sign["albedo_psnr"] >= 0.3, got
    assert good["nvs_psnr"] - sign["nvs_psnr"] >= 0.8, got
    assert sign["roughness_mse"] >= 1.15 * good["roughness_mse"], got


@pytest.mark.parametrize("layout", ["inria_sh3", "mip_splatting_sh0", "supersplat_compressed", "2dgs_sh3"])
def test_other_tools_layouts_give_materials(cli, capture, tmp_path, layout):
    """The fitted splats as other tools write them, through the command at a quick setting: finite albedos
    in [0, 1], not constant, following the sphere's colours (warm top, cool bottom: the red-minus-blue
    of the albedo correlates with the truth's across the splats)."""
    rec = splat_layouts.read_vertices(capture["fitted"])
    ply = tmp_path / (layout + ".ply")
    if layout == "inria_sh3":
        splat_layouts.write_inria(ply, rec)
    elif layout == "mip_splatting_sh0":
        # filter_3D: Mip-Splatting's 0.2 x distance / focal length (3.6 / 51 px at 40 px and 0.75 rad)
        splat_layouts.write_mip_splatting_sh0(ply, rec, 0.2 * 3.6 / (20 / math.tan(0.375)))
    elif layout == "2dgs_sh3":
        # the fitted splats are surfels already (made with a 1e-3 third scale): their thin axis is z
        assert np.mean(rec["scale_2"] < np.minimum(rec["scale_0"], rec["scale_1"])) > 0.99
        splat_layouts.write_2dgs(ply, rec)
    else:
        splat_layouts.write_supersplat_from(ply, rec)
    out = tmp_path / "out"
    # --up z: the sphere's capture is Blender's (+z up), which a file in another tool's layout does not say
    # (without SH evidence such a file is read as a trainer's, -y up: docs/relightable.md#up-axis).
    r = run([cli, "optimize", "--gaussians", ply, "--out", out, "--iters", "150", "--spp", "4", "--crop", "0",
             "--orbit-views", "12", "--orbit-size", "32", "--env-size", "16x8", "--threads", "2", "--up", "z"])
    assert ("roughness and metallic are unconstrained" in r.stderr) == (layout == "mip_splatting_sh0")
    res = splat_layouts.read_vertices(out / "gaussians.ply")
    albedo = np.stack([res["albedo_%d" % c] for c in range(3)], 1)
    pos = np.stack([res[c] for c in "xyz"], 1)
    assert np.all(np.isfinite(albedo)) and np.all(np.isfinite(res["roughness"]))
    assert albedo.min() >= 0 and albedo.max() <= 1
    keep = (1 / (1 + np.exp(-res["opacity"])) > 0.5) & (np.abs(pos[:, 2]) > 0.2)  # opaque, off the colour seam
    truth = np.where(pos[keep, 2:3] > 0, [[0.7, 0.3, 0.2]], [[0.2, 0.5, 0.7]])
    warmth = albedo[keep, 0] - albedo[keep, 2]
    corr = np.corrcoef(warmth, truth[:, 0] - truth[:, 2])[0, 1]
    print(layout, "albedo mean", albedo[keep].mean(0), "std", albedo[keep].std(0), "correlation", corr)
    # Measured: red std 0.134, 0.135, 0.134 and correlation 0.944, 0.926, 0.943 (INRIA, Mip-Splatting,
    # SuperSplat); a grey or constant albedo gives std ~0 and no correlation. Bounds: about half the margin.
    assert albedo[keep].std(0).max() > 0.06, albedo[keep].std(0)
    assert corr > 0.7, corr


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
