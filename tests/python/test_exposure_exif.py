"""EXIF exposure of real captures (io/photo_exposure.h): photos of equal content
taken with different ExposureTime / FNumber / ISO are divided by t S / N^2
relative to the capture's median; --ignore-exif (exif_exposure=False) keeps
them as stored. The EXIF tags are written by OpenImageIO's own oiiotool, the
way a camera's JPEGs carry them.
"""

import shutil
import subprocess
import sys

import numpy as np
import pytest

from ptir_testing import MODULE_DIR, REPO

sys.path.insert(0, str(REPO / "scripts"))
sys.path.insert(0, str(MODULE_DIR))
from dataset import layouts as cl  # noqa: E402
import ptir  # noqa: E402

OIIOTOOL = shutil.which("oiiotool")
W, H = 16, 12
# (ExposureTime s, FNumber, ISO) per photo; H = t S / N^2.
SETTINGS = [(1 / 100, 4.0, 200), (1 / 50, 4.0, 200), (1 / 100, 2.0, 200), (1 / 100, 4.0, 800), (1 / 200, 4.0, 200)]


def write_capture(root, exif=True):
    names = ["p%d.jpg" % i for i in range(len(SETTINGS))]
    imgs = []
    for i, n in enumerate(names):
        a = 2 * np.pi * i / len(names)
        C = 4.0 * np.array([np.cos(a), np.sin(a), 0.3])
        fwd = -C / np.linalg.norm(C)
        right = np.cross(fwd, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        R = np.stack([right, np.cross(fwd, right), fwd])
        imgs.append((i + 1, cl.quat_from_rotation(R), -R @ C, 1, n, np.zeros((0, 2)), np.zeros(0, np.int64)))
    cl.write_colmap_bin(root / "sparse" / "0", {1: ("PINHOLE", W, H, [14.0, 14.0, W / 2, H / 2])}, imgs)
    (root / "images").mkdir(parents=True)
    src = root / "grey.png"
    ptir.write_image(str(src), np.full((H, W, 3), 0.2, np.float32))
    for n, (t, f, iso) in zip(names, SETTINGS):
        cmd = [OIIOTOOL, str(src)]
        if exif:
            cmd += ["--attrib:type=float", "ExposureTime", repr(t), "--attrib:type=float", "FNumber", repr(f),
                    "--attrib:type=int", "Exif:PhotographicSensitivity", str(iso)]
        subprocess.run(cmd + ["-o", str(root / "images" / n)], check=True, capture_output=True)
    src.unlink()
    return root


@pytest.mark.skipif(OIIOTOOL is None, reason="oiiotool is not installed")
def test_exif_exposure_divides_each_photo_by_its_relative_exposure(tmp_path):
    root = write_capture(tmp_path / "cap")
    ds = ptir.load_dataset(str(root), split="all")
    h = np.array([t * s / (f * f) for t, f, s in SETTINGS])
    expect = h / np.median(h)
    np.testing.assert_allclose(ds.exposures, expect, rtol=1e-3)
    base = ptir.load_dataset(str(root), split="all", exif_exposure=False)
    assert base.exposures == [1.0] * len(SETTINGS)
    for i in range(len(ds)):
        got, stored = ds.target(i)[0], base.target(i)[0]
        np.testing.assert_allclose(got * ds.exposures[i], stored, rtol=1e-5)  # EXIF stores t as a rational
    # Train and test views keep the whole capture's reference.
    test = ptir.load_dataset(str(root), split="test", holdout=2)
    assert test.exposures == pytest.approx([expect[0], expect[2], expect[4]], rel=1e-3)


@pytest.mark.skipif(OIIOTOOL is None, reason="oiiotool is not installed")
def test_photos_without_exif_keep_their_values(tmp_path):
    root = write_capture(tmp_path / "cap", exif=False)
    assert ptir.load_dataset(str(root), split="all").exposures == [1.0] * len(SETTINGS)


@pytest.mark.skipif(OIIOTOOL is None, reason="oiiotool is not installed")
def test_eval_reads_a_capture_result_as_its_run_did(tmp_path):
    """`ptir eval` on a capture's result: where the capture stage left the EXIF exposure out
    (RESULT/capture/calibration.json) the photos are scored as stored, and the capture's coverage
    masks give the object's PSNR beside the frame's."""
    import json
    from ptir_testing import CLI, write_splat_ply
    root = write_capture(tmp_path / "cap")
    # The photos: 0.2 on the left half, 0.35 on the right, each with its EXIF (write_capture's settings).
    half = np.full((H, W, 3), 0.2, np.float32)
    half[:, W // 2:] = 0.35
    src = tmp_path / "half.png"
    ptir.write_image(str(src), half)
    for i, (t, f, iso) in enumerate(SETTINGS):
        subprocess.run([OIIOTOOL, str(src), "--attrib:type=float", "ExposureTime", repr(t), "--attrib:type=float",
                        "FNumber", repr(f), "--attrib:type=int", "Exif:PhotographicSensitivity", str(iso), "-o",
                        str(root / "images" / ("p%d.jpg" % i))], check=True, capture_output=True)
    # The result: a sky of 0.2 and one small splat far behind the cameras' backs (every pixel sees the sky).
    res = tmp_path / "result"
    res.mkdir()
    write_splat_ply(res / "gaussians.ply", [[0.0, 0.0, 40.0]], (0.01, 0.01, 0.01))
    ptir.write_image(str(res / "env.exr"), np.full((8, 16, 3), 0.2, np.float32))
    test_names = ptir.load_dataset(str(root), split="test", holdout=2).view_names

    def evaluate():
        r = subprocess.run([str(CLI), "eval", "--dataset", str(root), "--result", str(res), "--holdout", "2", "--spp",
                            "4", "--aov-spp", "1", "--sheet-views", "0", "-q"], capture_output=True, text=True,
                           timeout=300)
        assert r.returncode == 0, r.stderr
        return json.loads((res / "eval" / "metrics.json").read_text())

    # Without the capture's record: EXIF applied (test photos 0.5x, 2x, 0.25x the median), no object.
    m = evaluate()
    assert m["nvs_psnr"] < 15.0 and m["nvs_psnr_object"] is None
    # The capture stage's record: EXIF left out, the left half the object.
    (res / "capture" / "masks").mkdir(parents=True)
    mask = np.zeros((H, W, 3), np.float32)
    mask[:, : W // 2] = 1.0
    for n in test_names:
        ptir.write_image(str(res / "capture" / "masks" / (n + ".png")), mask, colour=False)
    (res / "capture" / "calibration.json").write_text(json.dumps(
        {"subject": "object", "exif_exposure": False, "masks": "masks", "views": {}}))
    m = evaluate()
    # The frame: the right half 0.35 against the sky's 0.2 (sRGB 0.63 vs 0.48: ~19.5 dB); the object exact.
    assert 18.0 < m["nvs_psnr"] < 21.0, m["nvs_psnr"]
    assert m["nvs_psnr_object"] > 38.0, m["nvs_psnr_object"]
    assert all("nvs_psnr_object" in v for v in m["per_view"])
