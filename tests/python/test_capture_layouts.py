"""One synthetic capture in every layout (scripts/dataset/capture.py): NeRF
(pinhole), COLMAP binary and text and nerfstudio (OPENCV lens, distorted photos,
masks) give the same cameras and recover the same albedo.

The capture is rendered here by the module: a sphere of flat Gaussians, warm top
and cool bottom, under a sky with a sun, 16 views at 40x40 (views 0 and 8 are the
test views of every layout). Each layout is optimised briefly with the same
settings; the recovered per-Gaussian albedo is scored against the truth
(scale-aligned per channel, as the evaluation does).
"""

import json
import math
import shutil
import subprocess
import sys

import numpy as np
import pytest

from blender_kit import look_at
from ptir_testing import REPO, sphere_scene

sys.path.insert(0, str(REPO / "scripts"))
from dataset import capture  # noqa: E402

RES, N_VIEWS, FOV_X = 40, 16, 0.7


@pytest.fixture(scope="module")
def capture_dirs(ptir, tmp_path_factory):
    src = tmp_path_factory.mktemp("capture_src")
    n = 500
    mats = []
    for i in range(N_VIEWS):
        phi = 2 * math.pi * i / N_VIEWS
        mats.append(look_at((3.5 * math.cos(phi), 3.5 * math.sin(phi), 0.4 + 0.9 * (i % 3) - 0.9), (0, 0, 0)))
    frames = [{"file_path": "v%d" % i, "transform_matrix": m.tolist()} for i, m in enumerate(mats)]
    # Rendered at twice the photo size: the photos are box-filtered down after the lens warp.
    (src / "cams.json").write_text(json.dumps({"camera_angle_x": FOV_X, "w": 2 * RES, "h": 2 * RES, "frames": frames}))
    scene, _, truth = sphere_scene(ptir, src, n, ((1.3, 0.12), (1.2, 0.1)), "cams.json")
    scene.gaussians.roughness = np.full(n, 0.6, np.float32)
    views = []
    for i in range(N_VIEWS):
        img = scene.render(i, spp=8, bounces=2)
        views.append(("view_%02d" % i, mats[i], img[..., :3], img[..., 3]))
    f = 0.5 * RES / math.tan(0.5 * FOV_X)
    made = capture.write_capture_layouts(src / "layouts", views, (f, f, RES / 2, RES / 2), supersample=2)
    return {"layouts": made, "ply": src / "g.ply", "truth": truth, "mats": mats, "f": f, "env": src / "env.exr"}


def test_every_layout_has_the_same_cameras(ptir, capture_dirs):
    made = capture_dirs["layouts"]
    assert sorted(made) == sorted(capture.LAYOUTS)
    for split, count in (("train", N_VIEWS - 2), ("test", 2)):
        ref = {c.name: c for c in ptir.load_dataset(str(made["nerf"]), split=split).cameras}
        assert len(ref) == count
        for name in ("colmap_bin", "colmap_txt", "nerfstudio"):
            ds = ptir.load_dataset(str(made[name]), split=split)
            assert ds.layout == ("colmap" if name.startswith("colmap") else "nerfstudio")
            got = {c.name: c for c in ds.cameras}
            assert sorted(got) == sorted(ref), name
            for n, c in got.items():
                r = ref[n]
                np.testing.assert_allclose(np.array(c.camera_to_world), np.array(r.camera_to_world), atol=1e-5)
                assert abs(c.fx - r.fx) < 1e-5 and abs(c.fy - r.fy) < 1e-5
                # The undistorted photo is a whole-pixel window of the pinhole image: the
                # principal point moves by the window's integer origin.
                for k in ("cx", "cy"):
                    shift = getattr(r, k) - getattr(c, k)
                    assert abs(shift - round(shift)) < 1e-5 and round(shift) >= 0, (name, n, k, shift)
    # And they are the matrices written (NeRF layout, independent of the readers).
    allc = {c.name: c for c in ptir.load_dataset(str(made["colmap_bin"]), split="all").cameras}
    for i, m in enumerate(capture_dirs["mats"]):
        np.testing.assert_allclose(np.array(allc["view_%02d" % i].camera_to_world), m, atol=1e-5)


def aligned_psnr(est, truth):
    """PSNR of est against truth (rows of RGB) after a per-channel least-squares scale
    (the albedo/light ambiguity), as the evaluation aligns albedo."""
    s = (est * truth).sum(0) / np.maximum((est * est).sum(0), 1e-12)
    mse = np.mean((np.clip(est * s, 0, 1) - truth) ** 2)
    return 10 * math.log10(1.0 / mse)


def albedo_views(ptir, field, cams):
    """The albedo AOV of every camera, pixels the object covers (rows of RGB)."""
    scene = ptir.Scene(field)
    px = []
    for c in cams:
        img = scene.render_aov(c, "albedo", spp=4, seed=1)
        px.append(img[..., :3][img[..., 3] > 0.99])
    return np.concatenate(px)


def test_every_layout_recovers_the_same_albedo(ptir, cli, capture_dirs, tmp_path):
    cams = [c for split in ("train", "test") for c in ptir.load_dataset(str(capture_dirs["layouts"]["nerf"]), split=split).cameras]
    truth_field = ptir.load_gaussians(str(capture_dirs["ply"]))
    truth_field.albedo = capture_dirs["truth"]
    truth = albedo_views(ptir, truth_field, cams)
    psnr = {}
    for name, root in capture_dirs["layouts"].items():
        out = tmp_path / name
        cmd = [str(cli), "optimize", "--dataset", str(root), "--gaussians", str(capture_dirs["ply"]), "--out", str(out),
               "--iters", "60", "--spp", "4", "--bounces", "1", "--env", "latlong", "--env-size", "16x8",
               "--threads", "2", "--seed", "3", "-q", "--fit-iters", "0", "--lambda-ssim", "0.2"]
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr[-2000:]
        field = ptir.load_gaussians(str(out / "gaussians.ply"))
        psnr[name] = aligned_psnr(albedo_views(ptir, field, cams), truth)
    print("albedo PSNR (16 views) by layout: " + ", ".join("%s %.2f dB" % kv for kv in sorted(psnr.items())))
    start = aligned_psnr(np.full_like(truth, 0.3), truth)
    assert min(psnr.values()) > start + 3.0, (psnr, start)  # it did recover something
    # The layouts differ only by the OPENCV lens (the NeRF twin's images are undistorted by the maker,
    # COLMAP's by the loader: one resampling apart). Measured spread: 0.29 dB without the light-albedo
    # balance (19.74 / 20.03 dB), 0.31-0.33 dB with it (20.03-20.86 / 20.34-21.19 dB); with the bounded
    # self-skip 0.21 dB (18.72 / 18.93). The run keeps PTIR's D-SSIM (0.2), which these bounds were
    # measured with: this 60-iteration run recovers 1.2 dB less without it (17.52 / 17.74 dB, start
    # 14.83), the default since the 400-iteration object sets gain from dropping it (docs/objective.md).
    assert max(psnr.values()) - min(psnr.values()) < 0.4, psnr


def test_learned_exposure_finds_darker_photos(ptir, cli, capture_dirs, tmp_path):
    """--learn-exposure: four training photos 0.6x as bright (linear) come out with
    exposure ~0.6 relative to the others (the mean log exposure is held at 0)."""
    root = tmp_path / "nerf"
    shutil.copytree(capture_dirs["layouts"]["nerf"], root)
    dark = ["view_01", "view_02", "view_03", "view_04"]
    for n in dark:
        f = root / "images" / (n + ".png")
        img = ptir.read_image(str(f))
        img[..., :3] *= 0.6
        ptir.write_image(str(f), img)
    out = tmp_path / "res"
    r = subprocess.run([str(cli), "optimize", "--dataset", str(root), "--gaussians", str(capture_dirs["ply"]), "--out",
                        str(out), "--iters", "90", "--spp", "4", "--bounces", "1", "--env", "latlong", "--env-size",
                        "16x8", "--threads", "2", "--seed", "3", "-q", "--learn-exposure", "--fit-iters", "0",
                        # PTIR's environment rate: 90 iterations are too few for the default's half rate
                        # (set for runs of hundreds of iterations; docs/inversion.md)
                        "--lr-env", "0.035"], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    e = json.loads((out / "exposure.json").read_text())
    assert sorted(e) == sorted("view_%02d" % i for i in range(N_VIEWS) if i % 8)  # training views only
    assert abs(sum(math.log(v) for v in e.values())) < 1e-3
    ratio = np.mean([e[n] for n in dark]) / np.mean([v for n, v in e.items() if n not in dark])
    print("learned exposure: darkened / others %.3f (truth 0.6); %s" % (ratio, {k: round(v, 3) for k, v in e.items()}))
    assert 0.5 < ratio < 0.72, e


def test_eval_of_an_unmasked_capture_compares_whole_photos(ptir, cli, capture_dirs, tmp_path):
    """Without masks the photos show the environment behind the object, and `ptir eval` renders
    it too: the true materials and environment reproduce the held-out photos (a render on a
    transparent film composited over white scored 8.5 dB on bench/bench_capture_masks.py's capture)."""
    src = capture_dirs["layouts"]["colmap_bin"]
    cap = tmp_path / "unmasked"
    cap.mkdir()
    for sub in ("sparse", "images"):
        (cap / sub).symlink_to(src / sub)
    res = tmp_path / "oracle"
    res.mkdir()
    field = ptir.load_gaussians(str(capture_dirs["ply"]))
    field.albedo = capture_dirs["truth"]
    field.roughness = np.full(len(capture_dirs["truth"]), 0.6, np.float32)
    ptir.save_gaussians(str(res / "gaussians.ply"), field)
    shutil.copy(capture_dirs["env"], res / "env.exr")
    psnr = {}
    for name, ds in (("unmasked", cap), ("masked", src)):
        r = subprocess.run([str(cli), "eval", "--dataset", str(ds), "--result", str(res), "--spp", "16", "--aov-spp", "1",
                            "--sheet-views", "0", "--threads", "2", "-q", "--force"], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr[-2000:]
        psnr[name] = json.loads((res / "eval" / "metrics.json").read_text())["nvs_psnr"]
    print("oracle NVS on the held-out photos: %s" % psnr)
    assert psnr["unmasked"] > 24 and psnr["masked"] > 24, psnr
