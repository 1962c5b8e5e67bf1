"""The evaluation metrics (ptir.metrics, src/ptir/eval/metrics.h) against
scikit-image and numpy on small arrays, and `ptir eval`'s protocol on a result
whose answers are known exactly (a dataset written from the renderer itself)."""

import json
import math
import subprocess

import numpy as np
import pytest
import skimage.metrics

from blender_kit import look_at
from ptir_testing import write_splat_ply


@pytest.fixture(scope="module")
def rng():
    return np.random.default_rng(7)


def smooth_image(rng, h, w, c=3):
    """Random but spatially correlated values in [0, 1] (SSIM is meaningless on white noise)."""
    base = rng.random((h // 4 + 2, w // 4 + 2, c))
    img = np.kron(base, np.ones((4, 4, 1)))[:h, :w]
    return np.clip(img + 0.05 * rng.standard_normal((h, w, c)), 0, 1).astype(np.float32)


def test_psnr_matches_skimage(ptir, rng):
    a = smooth_image(rng, 24, 31)
    b = np.clip(a + 0.03 * rng.standard_normal(a.shape), 0, 1).astype(np.float32)
    ref = skimage.metrics.peak_signal_noise_ratio(a.astype(np.float64), b.astype(np.float64), data_range=1.0)
    assert ptir.metrics.psnr(a, b) == pytest.approx(ref, abs=1e-4)
    assert ptir.metrics.mse(a, b) == pytest.approx(np.mean((a.astype(np.float64) - b) ** 2), rel=1e-6)
    assert math.isinf(ptir.metrics.psnr(a, a))


def test_masked_psnr_matches_numpy(ptir, rng):
    a, b = smooth_image(rng, 20, 20), smooth_image(rng, 20, 20)
    alpha = rng.random((20, 20)).astype(np.float32)
    fg = alpha > 0.5
    ref = 10 * np.log10(1.0 / np.mean((a[fg].astype(np.float64) - b[fg]) ** 2))
    assert ptir.metrics.psnr(a, b, alpha) == pytest.approx(ref, abs=1e-4)
    # An RGBA image as mask: its last channel is the alpha.
    rgba = np.concatenate([a, alpha[..., None]], -1)
    assert ptir.metrics.psnr(a, b, rgba) == pytest.approx(ref, abs=1e-4)


@pytest.mark.parametrize("shape", [(32, 40), (11, 64), (64, 23)])
def test_ssim_matches_skimage(ptir, rng, shape):
    a = smooth_image(rng, *shape)
    b = np.clip(0.9 * a + 0.05 + 0.04 * rng.standard_normal(a.shape), 0, 1).astype(np.float32)
    ref = skimage.metrics.structural_similarity(a.astype(np.float64), b.astype(np.float64), gaussian_weights=True,
                                                sigma=1.5, use_sample_covariance=False, data_range=1.0, channel_axis=2)
    assert ptir.metrics.ssim(a, b) == pytest.approx(ref, abs=2e-4)


def test_albedo_scale_is_the_numpy_median_over_all_views(ptir, rng):
    gts, preds, masks, ratios = [], [], [], [[], [], []]
    for n in (5, 6):  # an odd and an even count of pixels in total per channel: 11 -> the middle one
        g = rng.uniform(0.05, 0.9, (n, 4, 3)).astype(np.float32)
        p = rng.uniform(0.05, 0.9, (n, 4, 3)).astype(np.float32)
        m = (rng.random((n, 4)) > 0.4).astype(np.float32)
        gts.append(g), preds.append(p), masks.append(m)
        for c in range(3):
            ratios[c].extend((g[..., c] / p[..., c])[m > 0.5])
    s = ptir.metrics.albedo_scale(gts, preds, masks)
    for c in range(3):
        assert s[c] == pytest.approx(np.median(np.asarray(ratios[c], np.float32)), rel=1e-6)
    # Even count: numpy's mean of the two middle values.
    assert ptir.metrics.median([1.0, 4.0, 2.0, 3.0]) == 2.5
    aligned = ptir.metrics.apply_scale(preds[0], s)
    assert np.allclose(aligned, np.clip(preds[0] * np.asarray(s, np.float32), 0, 1), atol=1e-6)


def test_normal_mae_and_roughness_mse_match_numpy(ptir, rng):
    g = rng.standard_normal((9, 7, 3))
    g /= np.linalg.norm(g, axis=-1, keepdims=True)
    p = g + 0.3 * rng.standard_normal(g.shape)
    m = (rng.random((9, 7)) > 0.3).astype(np.float32)
    cos = np.sum(g * p, -1) / np.linalg.norm(p, axis=-1)
    ref = np.degrees(np.arccos(np.clip(cos, -1, 1)))[m > 0.5].mean()
    assert ptir.metrics.normal_mae(g.astype(np.float32), p.astype(np.float32), m) == pytest.approx(ref, abs=1e-3)
    rg, rp = rng.random((9, 7)).astype(np.float32), rng.random((9, 7)).astype(np.float32)
    ref_r = np.mean(np.where(m > 0.5, rg - rp, 0.0) ** 2)  # background zeroed, whole image
    assert ptir.metrics.roughness_mse(rg, rp, m) == pytest.approx(ref_r, rel=1e-5)


def test_composite_srgb(ptir):
    rgb = np.full((1, 2, 3), 0.5, np.float32)
    alpha = np.array([[1.0, 0.25]], np.float32)
    c = ptir.metrics.composite_srgb(rgb, alpha)
    s = 1.055 * 0.5 ** (1 / 2.4) - 0.055
    assert c[0, 0, 0] == pytest.approx(s, abs=1e-6)
    assert c[0, 1, 0] == pytest.approx(0.25 * s + 0.75, abs=1e-6)


# ---------------------------------------------------------------- the protocol on exact answers

def srgb(x):
    x = np.clip(x, 0, 1)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def to_png(path, rgba_straight_linear, colour=True):
    import skimage.io
    rgb = srgb(rgba_straight_linear[..., :3]) if colour else np.clip(rgba_straight_linear[..., :3], 0, 1)
    out = np.concatenate([rgb, rgba_straight_linear[..., 3:]], -1)
    skimage.io.imsave(str(path), np.rint(out * 255).astype(np.uint8), check_contrast=False)


def test_eval_scores_a_self_rendered_dataset(ptir, cli, tmp_path):
    """A dataset whose 'ground truth' is ptir's own AOVs of a result: albedo PSNR
    must be near-perfect after the scale (we halve the stored albedo: s = 2),
    roughness MSE ~ quantisation, normal MAE ~ 8-bit quantisation."""
    # A sphere of flat Gaussians with known materials, written as a result folder.
    n = 600
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    r = np.sqrt(1 - z * z)
    phi = i * 2.39996323
    nrm = np.stack([r * np.cos(phi), r * np.sin(phi), z], 1)
    spacing = math.sqrt(4 * math.pi / n) * 0.6
    # Rotation taking local z to the normal (w, x, y, z): half-way quaternion.
    zax = np.array([0, 0, 1.0])
    h = nrm + zax
    bad = np.linalg.norm(h, axis=1) < 1e-6
    h[bad] = [1, 0, 0]
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    q = np.column_stack([np.sum(zax * h, 1), np.cross(zax, h)])
    result = tmp_path / "result"
    result.mkdir()
    write_splat_ply(result / "plain.ply", nrm * 0.6, (0.7 * spacing, 0.7 * spacing, 1e-3 * spacing), quat=q, opacity=0.99)
    scene_albedo = np.where(nrm[:, :1] > 0, [0.6, 0.2, 0.1], [0.1, 0.3, 0.5])
    field = ptir.load_gaussians(str(result / "plain.ply"))
    field.albedo = (0.5 * scene_albedo).astype(np.float32)      # the "recovered" albedo is off by 2x
    field.roughness = np.where(nrm[:, 2] > 0, 0.3, 0.7).astype(np.float32)
    field.metallic = np.zeros(n, np.float32)
    field.normal = nrm.astype(np.float32)
    ptir.save_gaussians(str(result / "gaussians.ply"), field)
    env = np.full((8, 16, 3), 0.8, np.float32)
    ptir.write_image(str(result / "env.exr"), env)

    # The dataset: two views, ground truth = the renderer's AOVs with the true albedo.
    data = tmp_path / "data"
    mats = [look_at((2.5, -1.0, 0.8)), look_at((-2.0, -1.6, -0.5))]
    frames = [{"file_path": "./test_%03d/rgba" % k, "transform_matrix": m.tolist()} for k, m in enumerate(mats)]
    data.mkdir()
    (data / "transforms_test.json").write_text(json.dumps({"camera_angle_x": 0.69, "w": 40, "h": 40, "frames": frames}))
    truth = ptir.load_gaussians(str(result / "gaussians.ply"))
    truth.albedo = scene_albedo.astype(np.float32)
    ptir.save_gaussians(str(tmp_path / "truth.ply"), truth)
    cams = ptir.load_cameras(str(data / "transforms_test.json"))
    scene = ptir.Scene(ptir.load_gaussians(str(tmp_path / "truth.ply")))
    for k, cam in enumerate(cams):
        v = data / ("test_%03d" % k)
        v.mkdir()
        alb = scene.render_aov(cam, "albedo", spp=16)
        rough = scene.render_aov(cam, "roughness", spp=16)
        nor = scene.render_aov(cam, "normal", spp=16)
        a = alb[..., 3:]
        to_png(v / "rgba.png", np.concatenate([alb[..., :3], a], -1))  # any image: only NVS uses it
        to_png(v / "albedo.png", alb)
        to_png(v / "roughness.png", np.concatenate([np.repeat(rough[..., :1], 3, -1), a], -1), colour=False)
        to_png(v / "normal.png", np.concatenate([np.where(a > 0, 0.5 + 0.5 * nor[..., :3], 0), a], -1), colour=False)

    r = subprocess.run([str(cli), "eval", "--dataset", str(data), "--result", str(result), "--spp", "4",
                        "--aov-spp", "16", "-q"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "| Albedo PSNR" in r.stdout
    m = json.loads((result / "eval" / "metrics.json").read_text())
    assert m["views"] == 2
    assert m["albedo_scale"] == pytest.approx([2.0, 2.0, 2.0], rel=0.02)
    assert m["albedo_psnr"] > 40.0               # 8-bit quantisation and the scale's 1-2 % only
    assert m["roughness_mse"] < 1e-4             # 8-bit quantisation (1/255)^2/12 ~ 1.3e-6, edges
    assert m["normal_mae_deg"] < 1.0             # 8-bit normals: ~0.2 deg
    for k in range(2):
        for f in ("rgba", "albedo", "roughness", "metallic", "normal"):
            assert (result / "eval" / ("test_%03d" % k) / (f + ".exr")).exists()
    assert {"sheet_nvs.png", "sheet_albedo.png", "sheet_roughness.png", "sheet_normal.png"} <= set(m["sheets"])
    assert (result / "eval" / "metrics.md").read_text().count("|") > 20
    # The same protocol from Python, with a progress callback.
    lines = []
    d = ptir.evaluate(str(data), str(result), spp=4, aov_spp=16, sheet_views=0, log=lines.append)
    assert d["albedo_scale"] == pytest.approx(m["albedo_scale"]) and d["sheets"] == []
    assert d["roughness_mse"] == pytest.approx(m["roughness_mse"])
    assert any(l.startswith("eval test_001") for l in lines)

    # Photos without material truth: the recovered materials beside them (sheet_materials.png:
    # photo | albedo | roughness | normal), in place of the scored sheets.
    for k in range(2):
        for f in ("albedo", "roughness", "normal"):
            (data / ("test_%03d" % k) / (f + ".png")).unlink()
    r = subprocess.run([str(cli), "eval", "--dataset", str(data), "--result", str(result), "--spp", "4",
                        "--aov-spp", "16", "-q"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    m = json.loads((result / "eval" / "metrics.json").read_text())
    assert "sheet_materials.png" in m["sheets"] and "sheet_albedo.png" not in m["sheets"]
    sheet = ptir.read_image(str(result / "eval" / "sheet_materials.png"), linear=False)[..., :3]
    h, w = sheet.shape[:2]
    assert w - 10 == 2 * (h - 6)                 # two rows of four 40-pixel tiles, 2-pixel gaps
    tile = (h - 6) // 2
    albedo_tile = sheet[2:2 + tile, 4 + tile:4 + 2 * tile].reshape(-1, 3)
    # The albedo tile shows the recovered albedo (0.5 x the two hemispheres' colours, sRGB) over white.
    want = np.where(np.asarray([0.3, 0.1, 0.05, 0.05, 0.15, 0.25]) <= 0.0031308, 0,
                    1.055 * np.asarray([0.3, 0.1, 0.05, 0.05, 0.15, 0.25]) ** (1 / 2.4) - 0.055).reshape(2, 3)
    sphere = albedo_tile[albedo_tile.sum(1) < 2.9]  # over white
    assert len(sphere) > 0.2 * len(albedo_tile)
    dist = np.min(np.linalg.norm(sphere[:, None, :] - want[None], axis=2), axis=1)
    assert np.mean(dist < 0.03) > 0.6, np.mean(dist < 0.03)  # most of the sphere: one of the two (0.76: soft rims)
