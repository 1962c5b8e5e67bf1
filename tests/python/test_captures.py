"""Real-capture layouts (docs/dataset_format.md): one synthetic capture written as
COLMAP (binary, text), NeRF, nerfstudio and 3DGS output gives the same cameras;
distorted lenses are undistorted to the pinhole the camera claims (checked
through the pixels against numpy's lens formulas); COLMAP's own model_converter
as an independent reference; instant-ngp's fox capture read as written; masks,
splits and errors.

Stand-in images are float EXRs whose pixel (i, j) holds its own source position
(R = i + 0.5, G = j + 0.5): bilinear resampling reproduces a linear function
exactly, so an undistorted image tells where each of its pixels came from.
"""

import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ptir_testing import CLI, MODULE_DIR, REPO, write_splat_ply

sys.path.insert(0, str(MODULE_DIR))
from dataset import layouts as cl  # noqa: E402  (scripts/dataset: ptir_testing put scripts/ on sys.path)
import ptir  # noqa: E402  (the build's module; the conftest fixture does the same)

W, H = 48, 36
PINHOLE = ("PINHOLE", [40.5, 41.25, 23.7, 18.4])
NAMES = ["view_%02d.exr" % i for i in range(10)]


def poses(n=len(NAMES)):
    """World-to-camera (R, t), COLMAP convention, cameras around the origin looking at it."""
    out = []
    for i in range(n):
        a = 2 * math.pi * i / n
        e = 0.3 + 0.2 * math.sin(3 * a)
        C = 4.0 * np.array([math.cos(a) * math.cos(e), math.sin(a) * math.cos(e), math.sin(e)])
        fwd = -C / np.linalg.norm(C)
        right = np.cross(fwd, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        down = np.cross(fwd, right)
        R = np.stack([right, down, fwd])  # rows: camera axes in the world
        out.append((R, -R @ C))
    return out


def write_position_images(folder, names, w=W, h=H):
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    img = np.stack([u, v, np.full_like(u, 0.25)], axis=2).astype(np.float32)
    for n in names:
        # Always EXR data, whatever the name says (OpenImageIO reads by content).
        tmp = folder / (n + ".tmp.exr")
        ptir.write_image(str(tmp), img)
        tmp.rename(folder / n)


def write_colmap(root, lens, binary=True, names=NAMES):
    model, params = lens
    cams = {1: (model, W, H, params)}
    imgs = [(i + 1, cl.quat_from_rotation(R), t, 1, n, np.zeros((0, 2)), np.zeros(0, np.int64))
            for i, (n, (R, t)) in enumerate(zip(names, poses(len(names))))]
    (cl.write_colmap_bin if binary else cl.write_colmap_txt)(Path(root) / "sparse" / "0", cams, imgs)
    write_position_images(Path(root) / "images", names)
    return Path(root)


def nerfstudio_intrinsics(lens):
    model, p = lens
    fx, fy, cx, cy = cl.focal_centre(model, p)
    d = {"fl_x": fx, "fl_y": fy, "cx": cx, "cy": cy, "w": W, "h": H}
    if model == "OPENCV":
        d.update(camera_model="OPENCV", k1=p[4], k2=p[5], p1=p[6], p2=p[7])
    return d


def write_nerfstudio(root, lens, extra=None):
    root = Path(root)
    frames = [("images/" + n, cl.opengl_c2w(R, t)) for n, (R, t) in zip(NAMES, poses())]
    cl.write_nerfstudio(root / "transforms.json", frames, nerfstudio_intrinsics(lens), extra)
    write_position_images(root / "images", NAMES)
    return root


def write_nerf(root, lens):
    root = Path(root)
    order = sorted(range(len(NAMES)), key=lambda i: NAMES[i])
    test = {order[k] for k in range(0, len(order), 8)}
    for split, members in (("train", [i for i in order if i not in test]), ("test", [i for i in order if i in test])):
        frames = [("./images/" + NAMES[i], cl.opengl_c2w(*poses()[i])) for i in members]
        cl.write_nerfstudio(root / ("transforms_%s.json" % split), frames, nerfstudio_intrinsics(lens))
    write_position_images(root / "images", NAMES)
    return root


def cameras(ds):
    return {c.name: c for c in ds.cameras}


def assert_same_cameras(a, b, tol=1e-5, intrinsics=True):
    assert sorted(a) == sorted(b)
    for n in a:
        ca, cb = a[n], b[n]
        np.testing.assert_allclose(np.array(ca.camera_to_world), np.array(cb.camera_to_world), atol=tol, err_msg=n)
        keys = ("fx", "fy", "cx", "cy", "width", "height") if intrinsics else ("fx", "fy", "width", "height")
        for k in keys:
            assert abs(getattr(ca, k) - getattr(cb, k)) <= tol * max(1.0, abs(getattr(ca, k))), (n, k)


def load(root, split="train", **kw):
    return ptir.load_dataset(str(root), split=split, **kw)


def test_same_capture_in_every_layout(tmp_path):
    roots = {"colmap_bin": write_colmap(tmp_path / "colmap_bin", PINHOLE, binary=True),
             "colmap_txt": write_colmap(tmp_path / "colmap_txt", PINHOLE, binary=False),
             "nerf": write_nerf(tmp_path / "nerf", PINHOLE),
             "nerfstudio": write_nerfstudio(tmp_path / "nerfstudio", PINHOLE)}
    cl.write_3dgs_output(tmp_path / "gs_out", roots["colmap_bin"],
                         [(Path(n).stem, W, H, 40.5, 41.25, R, t) for n, (R, t) in zip(NAMES, poses())])
    expected_layout = {"colmap_bin": "colmap", "colmap_txt": "colmap", "nerf": "nerf", "nerfstudio": "nerfstudio"}
    for split in ("train", "test"):
        ref = cameras(load(roots["colmap_bin"], split))
        assert len(ref) == (8 if split == "train" else 2)  # 10 views, every 8th (0 and 8) held out
        for name, root in roots.items():
            ds = load(root, split)
            assert ds.layout == expected_layout[name]
            assert_same_cameras(ref, cameras(ds))
        gs = load(tmp_path / "gs_out", split)
        assert gs.layout == "3dgs"
        # 3DGS renders with the principal point at the image centre.
        assert_same_cameras(ref, cameras(gs), intrinsics=False)
        assert all(c.cx == W / 2 and c.cy == H / 2 for c in gs.cameras)
        assert gs.gaussians_path.endswith("iteration_30000/point_cloud.ply")
    # The poses are the ones written, converted to ours independently (numpy).
    all_cams = cameras(load(roots["colmap_bin"], "all"))
    for n, (R, t) in zip(NAMES, poses()):
        c = all_cams[Path(n).stem]
        np.testing.assert_allclose(np.array(c.camera_to_world), cl.opengl_c2w(R, t), atol=1e-5)
        # A world point projected by COLMAP's pinhole formula lies on the ray through its pixel.
        X = np.array([[0.3, -0.2, 0.1]])
        uv = cl.project(*PINHOLE, R, t, X)[0]
        o, d = c.ray(float(uv[0]), float(uv[1]))
        v = X[0] - np.array(o)
        assert np.linalg.norm(np.cross(v, np.array(d))) < 1e-5 * np.linalg.norm(v)


DISTORTED = [
    ("OPENCV", [40.5, 41.25, 23.7, 18.4, -0.21, 0.06, 0.0015, -0.001]),
    ("SIMPLE_RADIAL", [40.5, 23.7, 18.4, 0.09]),
    ("RADIAL", [40.5, 23.7, 18.4, -0.15, 0.03]),
    ("FULL_OPENCV", [40.5, 41.25, 23.7, 18.4, -0.21, 0.06, 0.0015, -0.001, 0.01, 0.02, 0.005, 0.001]),
    ("OPENCV_FISHEYE", [30.0, 30.5, 23.7, 18.4, 0.04, -0.01, 0.002, -0.0004]),
]


def check_undistorted_pixels(ds, lens, truth, scale=1.0, src=(W, H)):
    """Every pixel of every undistorted view holds the source position numpy's lens
    formula gives for that pixel's ray (truth: name -> (R, t) world-to-camera)."""
    model, params = lens
    worst = 0.0
    for i, cam in enumerate(ds.cameras):
        R, t = truth[cam.name]
        rgb, alpha, has_alpha = ds.target(i)
        assert rgb.shape == (ds.height, ds.width, 3)
        # Rays through every pixel centre, as world points at depth 1, projected by numpy.
        ys, xs = np.mgrid[0:ds.height, 0:ds.width]
        pts = []
        for x, y in zip(xs.ravel(), ys.ravel()):
            o, d = cam.ray(float(x) + 0.5, float(y) + 0.5)
            pts.append(np.array(o) + np.array(d))
        uv = cl.project(model, params, R, t, np.array(pts)) * scale
        got = rgb[..., :2].reshape(-1, 2)
        err = np.abs(uv - got).max()
        worst = max(worst, err)
        # No blank or extrapolated pixel: every source position is between the outermost pixel centres.
        assert got[:, 0].min() >= 0.5 - 1e-3 and got[:, 0].max() <= src[0] - 0.5 + 1e-3
        assert got[:, 1].min() >= 0.5 - 1e-3 and got[:, 1].max() <= src[1] - 0.5 + 1e-3
    return worst


@pytest.mark.parametrize("lens", DISTORTED, ids=[m for m, _ in DISTORTED])
def test_distorted_lens_is_undistorted_to_the_cameras_pinhole(tmp_path, lens):
    root = write_colmap(tmp_path / "cap", lens, binary=(lens[0] != "OPENCV"))
    ds = load(root, "all", undistort_cache=str(tmp_path / "cache"))
    truth = {Path(n).stem: p for n, p in zip(NAMES, poses())}
    worst = check_undistorted_pixels(ds, lens, truth)
    print("%s: undistorted %dx%d of %dx%d, worst source position error %.2e px" % (lens[0], ds.width, ds.height, W, H, worst))
    assert worst < 1e-3
    assert ds.width <= W + 2 * W and ds.width > W // 2 and ds.height > H // 2
    # Cached: a second load reuses the files (same paths, no rewrite).
    files = [ds.files(i)["image"] for i in range(len(ds))]
    mtimes = [Path(f).stat().st_mtime_ns for f in files]
    assert all(Path(f).parent == tmp_path / "cache" for f in files)
    ds2 = load(root, "all", undistort_cache=str(tmp_path / "cache"))
    assert [ds2.files(i)["image"] for i in range(len(ds2))] == files
    assert [Path(f).stat().st_mtime_ns for f in files] == mtimes


@pytest.mark.parametrize("lens", DISTORTED, ids=[m for m, _ in DISTORTED])
def test_distorted_lens_at_a_working_size(tmp_path, lens):
    """Undistorted, then reduced (--max-image-side half the undistorted long side): each working pixel, the
    box average of the undistorted pixels' source positions, is where its ray projects through the lens
    (to second order: measured 0.002-0.006 px)."""
    root = write_colmap(tmp_path / "cap", lens, binary=True)
    full = load(root, "all", undistort_cache=str(tmp_path / "cache"))
    side = max(full.width, full.height) // 2
    ds = load(root, "all", undistort_cache=str(tmp_path / "cache"), max_image_side=side)
    assert ds.reduce >= 2 and max(ds.width, ds.height) <= side
    truth = {Path(n).stem: p for n, p in zip(NAMES, poses())}
    assert check_undistorted_pixels(ds, lens, truth) < 0.02


def test_nerfstudio_distorted_equals_colmap_distorted(tmp_path):
    lens = DISTORTED[0]
    a = load(write_colmap(tmp_path / "colmap", lens, binary=False), "all")
    b = load(write_nerfstudio(tmp_path / "ns", lens), "all")
    assert_same_cameras(cameras(a), cameras(b))
    # Default cache: next to the data.
    assert Path(a.files(0)["image"]).parent == tmp_path / "colmap" / "ptir_undistorted" / "images"


def test_images_folder_scales_the_intrinsics(tmp_path):
    root = write_colmap(tmp_path / "cap", DISTORTED[0], binary=True)
    # images_2: every image at half size (24 x 18).
    write_position_images(root / "images_2", NAMES, W // 2, H // 2)
    ds = load(root, "all", images="images_2")
    assert ds.width < W // 2 + 1
    truth = {Path(n).stem: p for n, p in zip(NAMES, poses())}
    # Positions in the half-size image are the full-size lens's divided by 2.
    assert check_undistorted_pixels(ds, DISTORTED[0], truth, scale=0.5, src=(W // 2, H // 2)) < 2e-3


def test_nerfstudio_dataparser_and_applied_transforms(tmp_path):
    root = write_nerfstudio(tmp_path / "ns", PINHOLE)
    base = cameras(load(root, "all", world="data"))
    T = np.array([[0.0, -1.0, 0.0, 0.5], [1.0, 0.0, 0.0, -0.25], [0.0, 0.0, 1.0, 2.0]])
    (root / "dataparser_transforms.json").write_text(json.dumps({"transform": T.tolist(), "scale": 0.3}))
    dp = cameras(load(root, "all"))  # auto: the dataparser frame when its file is there
    for n, c in base.items():
        m = np.array(c.camera_to_world)
        expect = np.eye(4)
        expect[:3, :3] = T[:, :3] @ m[:3, :3]
        expect[:3, 3] = 0.3 * (T[:, :3] @ m[:3, 3] + T[:, 3])
        np.testing.assert_allclose(np.array(dp[n].camera_to_world), expect, atol=1e-5)
    # applied_transform: world colmap undoes it.
    A = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0]])
    d = json.loads((root / "transforms.json").read_text())
    d["applied_transform"] = A.tolist()
    (root / "transforms.json").write_text(json.dumps(d))
    col = cameras(load(root, "all", world="colmap"))
    A4 = np.vstack([A, [0, 0, 0, 1]])
    for n, c in base.items():
        np.testing.assert_allclose(np.array(col[n].camera_to_world), np.linalg.inv(A4) @ np.array(c.camera_to_world),
                                   atol=1e-5)


COLMAP_BIN = shutil.which("colmap")


@pytest.mark.skipif(COLMAP_BIN is None, reason="colmap is not installed (apt-get install colmap)")
@pytest.mark.parametrize("lens", [DISTORTED[0], DISTORTED[4]], ids=["OPENCV", "OPENCV_FISHEYE"])
def test_colmap_model_converter_is_an_independent_reference(tmp_path, lens):
    """COLMAP itself converts our numpy-written models txt <-> bin; all four read alike."""
    txt = write_colmap(tmp_path / "txt", lens, binary=False)
    binr = write_colmap(tmp_path / "bin", lens, binary=True)
    out = {}
    for name, src, kind in (("txt2bin", txt, "BIN"), ("bin2txt", binr, "TXT")):
        dst = tmp_path / name
        (dst / "sparse" / "0").mkdir(parents=True)
        shutil.copytree(src / "images", dst / "images")
        subprocess.run([COLMAP_BIN, "model_converter", "--input_path", str(src / "sparse" / "0"),
                        "--output_path", str(dst / "sparse" / "0"), "--output_type", kind],
                       check=True, capture_output=True, env={"QT_QPA_PLATFORM": "offscreen", "PATH": "/usr/bin:/bin"})
        assert (dst / "sparse" / "0" / ("cameras." + kind.lower())).exists()
        out[name] = dst
    ref = cameras(load(txt, "all"))
    for root in (binr, out["txt2bin"], out["bin2txt"]):
        assert_same_cameras(ref, cameras(load(root, "all")), tol=1e-6)


FOX = REPO / "tests" / "data" / "fox" / "transforms.json"


def test_fox_intrinsics_and_distortion_are_read_as_written(tmp_path):
    """instant-ngp's fox (1080x1920, OPENCV k1 k2 p1 p2): images stand in at 1/8 size, in nerfstudio's
    downscale folder images_8 (photos smaller than their camera in the layout's own folder are refused)."""
    meta = json.loads(FOX.read_text())
    root = tmp_path / "fox"
    root.mkdir()
    shutil.copy(FOX, root / "transforms.json")
    w, h = int(meta["w"]) // 8, int(meta["h"]) // 8
    # EXR data under the .jpg names the file gives (OpenImageIO reads by content).
    write_position_images(root / "images_8", [Path(f["file_path"]).name for f in meta["frames"]], w, h)
    ds = load(root, "all", images="images_8", undistort_cache=str(tmp_path / "cache"))
    assert len(ds) == 67 and ds.layout == "nerfstudio"
    assert len(load(root, "test", images="images_8", undistort_cache=str(tmp_path / "cache"))) == 9  # every 8th
    s = 1 / 8
    for cam, fr in zip(sorted(ds.cameras, key=lambda c: c.name), sorted(meta["frames"], key=lambda f: f["file_path"])):
        assert cam.name == Path(fr["file_path"]).stem
        assert cam.fx == pytest.approx(meta["fl_x"] * s, rel=1e-6)
        assert cam.fy == pytest.approx(meta["fl_y"] * s, rel=1e-6)
        m = np.array(fr["transform_matrix"])
        m[:3, :3] /= np.linalg.norm(m[:3, :3], axis=0)
        np.testing.assert_allclose(np.array(cam.camera_to_world), m, atol=1e-5)
    # Distortion: the pixels come from where OpenCV's formula with the file's k1 k2 p1 p2 says.
    p = [meta["fl_x"], meta["fl_y"], meta["cx"], meta["cy"], meta["k1"], meta["k2"], meta["p1"], meta["p2"]]
    truth = {}
    for fr in meta["frames"]:
        c2w = np.array(fr["transform_matrix"])
        c2w[:3, :3] /= np.linalg.norm(c2w[:3, :3], axis=0)
        Rc = c2w[:3, :3] @ np.diag([1.0, -1.0, -1.0])  # COLMAP camera axes in the world
        truth[Path(fr["file_path"]).stem] = (Rc.T, -Rc.T @ c2w[:3, 3])
    sub = ptir.load_dataset(str(root), split="test", images="images_8", undistort_cache=str(tmp_path / "cache"))
    assert check_undistorted_pixels(sub, ("OPENCV", p), truth, scale=s, src=(w, h)) < 2e-3


def test_masks_black_background_and_unmasked(tmp_path):
    root = write_colmap(tmp_path / "cap", PINHOLE)
    ds = load(root, "all")
    rgb, alpha, has_alpha = ds.target(0)
    assert not has_alpha and alpha.min() == 1.0  # no mask: every pixel is supervised
    (root / "masks").mkdir()
    m = np.zeros((H, W), np.uint8)
    m[5:20, 10:30] = 255
    for n in NAMES:
        ptir.write_image(str(root / "masks" / (Path(n).stem + ".png")), (m / 255.0).astype(np.float32), colour=False)
    ds = load(root, "all")
    assert ds.files(0)["mask"].endswith("masks/view_00.png")
    rgb, alpha, has_alpha = ds.target(0)
    assert has_alpha
    np.testing.assert_array_equal(alpha, m / 255.0)
    # Black background: exactly-black pixels are background.
    shutil.rmtree(root / "masks")
    img = np.full((H, W, 3), 0.5, np.float32)
    img[:, :7] = 0
    ptir.write_image(str(root / "images" / NAMES[0]), img)
    rgb, alpha, has_alpha = load(root, "all", black_background=True).target(0)
    assert has_alpha and alpha[:, :7].max() == 0 and alpha[:, 7:].min() == 1


def test_large_photos_are_read_at_the_working_size(tmp_path):
    """--max-image-side: photos whose long side is over it are read box-averaged by the smallest integer
    factor that brings it under (48 x 36 under 20: 3, 16 x 12), the intrinsics divided by it; a mask at
    the photos' size is reduced with them, one at the working size is used as it is."""
    root = write_colmap(tmp_path / "cap", PINHOLE)
    full = load(root, "all", max_image_side=0)
    assert (full.width, full.height, full.reduce) == (W, H, 1)
    assert load(root, "all").reduce == 1  # the default (1600) leaves small photos alone
    ds = load(root, "all", max_image_side=20)
    assert (ds.width, ds.height, ds.reduce, ds.source_width, ds.source_height) == (16, 12, 3, W, H)
    assert load(root, "all", max_image_side=40).width == 24  # 48 / 40: factor 2
    # The position images hold each pixel's centre (u, v): a working pixel's is 3 (x + 0.5).
    rgb, alpha, _ = ds.target(0)
    u, v = np.meshgrid(np.arange(16) + 0.5, np.arange(12) + 0.5)
    np.testing.assert_allclose(rgb[..., 0], 3 * u, rtol=1e-6)
    np.testing.assert_allclose(rgb[..., 1], 3 * v, rtol=1e-6)
    cf, cr = cameras(full), cameras(ds)
    for n in cf:
        for k in ("fx", "fy", "cx", "cy"):
            assert abs(getattr(cr[n], k) - getattr(cf[n], k) / 3) < 1e-4, (n, k)
    # Masks: at the photos' size (reduced with them) and at the working size (as they are).
    (root / "masks").mkdir()
    m = np.zeros((H, W), np.float32)
    m[6:18, 12:30] = 1.0
    small = np.zeros((12, 16), np.float32)
    small[2:5, 3:9] = 1.0
    for i, n in enumerate(NAMES):
        ptir.write_image(str(root / "masks" / (Path(n).stem + ".png")), m if i % 2 == 0 else small, colour=False)
    ds = load(root, "all", max_image_side=20)
    _, a0, has_alpha = ds.target(0)
    assert has_alpha
    np.testing.assert_allclose(a0, m.reshape(12, 3, 16, 3).mean(axis=(1, 3)), atol=1e-6)
    np.testing.assert_array_equal(ds.target(1)[1], small)
    # A mask of neither size is an error naming it.
    ptir.write_image(str(root / "masks" / "view_01.png"), np.ones((10, 10), np.float32), colour=False)
    with pytest.raises(Exception, match="view_01.png.*mask is 10x10"):
        load(root, "all", max_image_side=20).target(1)


def test_photos_of_two_sizes_are_read_as_their_common_middle(tmp_path):
    """A phone's landscape (48 x 36) and portrait (36 x 48) photos in one capture: each is read as the
    36 x 36 about its centre, its principal point moved by the crop, and --max-image-side reduces after."""
    root = tmp_path / "cap"
    land = ("PINHOLE", W, H, [40.5, 41.25, 23.7, 18.4])
    port = ("PINHOLE", H, W, [41.0, 40.0, 17.9, 24.2])
    imgs = [(i + 1, cl.quat_from_rotation(R), t, 1 + i % 2, n, np.zeros((0, 2)), np.zeros(0, np.int64))
            for i, (n, (R, t)) in enumerate(zip(NAMES, poses()))]
    cl.write_colmap_bin(root / "sparse" / "0", {1: land, 2: port}, imgs)
    write_position_images(root / "images", NAMES[0::2], W, H)
    write_position_images(root / "images", NAMES[1::2], H, W)
    ds = load(root, "all")
    assert (ds.width, ds.height) == (36, 36)
    u, v = np.meshgrid(np.arange(36) + 0.5, np.arange(36) + 0.5)
    cams = cameras(ds)
    for i, n in enumerate(NAMES):
        rgb = ds.target(i)[0]
        dx, dy = (6, 0) if i % 2 == 0 else (0, 6)  # (48 - 36) / 2 on the long side
        np.testing.assert_allclose(rgb[..., 0], u + dx, rtol=1e-6)
        np.testing.assert_allclose(rgb[..., 1], v + dy, rtol=1e-6)
        p = (land if i % 2 == 0 else port)[3]
        c = cams[Path(n).stem]
        assert abs(c.cx - (p[2] - dx)) < 1e-4 and abs(c.cy - (p[3] - dy)) < 1e-4 and abs(c.fx - p[0]) < 1e-4
    # Reduced after the crop: 36 x 36 under 20 -> factor 2, 18 x 18.
    small = load(root, "all", max_image_side=20)
    assert (small.width, small.height, small.reduce) == (18, 18, 2)
    uu, vv = np.meshgrid(2 * (np.arange(18) + 0.5), 2 * (np.arange(18) + 0.5))
    np.testing.assert_allclose(small.target(1)[0][..., 1], vv + 6, rtol=1e-6)
    np.testing.assert_allclose(small.target(1)[0][..., 0], uu, rtol=1e-6)


def test_optimize_reads_a_3dgs_output_folder(tmp_path):
    src = write_colmap(tmp_path / "cap", PINHOLE)
    out = tmp_path / "gs"
    cl.write_3dgs_output(out, src, [(Path(n).stem, W, H, 40.5, 41.25, R, t) for n, (R, t) in zip(NAMES, poses())])
    for it in (7000, 30000):
        write_splat_ply(out / "point_cloud" / ("iteration_%d" % it) / "point_cloud.ply", [[0, 0, 0], [0.2, 0, 0]],
                        [0.3, 0.3, 0.01])
    r = subprocess.run([str(CLI), "optimize", "--dataset", str(out), "--out", str(tmp_path / "res"), "--iters", "1",
                        "--spp", "1", "--bounces", "0", "--threads", "2", "--fit-iters", "0"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "iteration_30000/point_cloud.ply" in r.stderr
    # The environment is the lat-long map for captures too (issue 38: 24 SGs cost 3.3 dB albedo).
    assert "8 train views 48x36" in r.stderr and "env latlong" in r.stderr
    assert (tmp_path / "res" / "gaussians.ply").exists()
    # At a working size the run says so, and its settings record it (a resume at another size is refused).
    r = subprocess.run([str(CLI), "optimize", "--dataset", str(out), "--out", str(tmp_path / "small"), "--iters", "1",
                        "--spp", "1", "--bounces", "0", "--threads", "2", "--fit-iters", "0", "--max-image-side", "20"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "8 train views 16x12" in r.stderr
    settings = json.loads((tmp_path / "small" / "settings.json").read_text())
    assert settings["image_size"] == "16x12" and settings["photos"] == "photos 48x36, read at 16x12 (1/3: --max-image-side 20)"


@pytest.mark.parametrize("case", ["missing_image", "wrong_aspect", "bad_split", "test_list", "ns_model", "cfg_source"])
def test_errors_name_the_file_and_problem(tmp_path, case):
    root = write_colmap(tmp_path / "cap", PINHOLE)
    kw, split, where, what = {}, "train", None, None
    if case == "missing_image":
        (root / "images" / NAMES[3]).unlink()
        where, what = str(root / "images" / NAMES[3]), "image not found"
    elif case == "wrong_aspect":
        write_position_images(root / "images_x", NAMES, W // 2, H)
        kw, where, what = {"images": "images_x"}, "images_x", "different aspect ratio"
    elif case == "bad_split":
        split, where, what = "val", str(root), "use train, test or all"
    elif case == "test_list":
        (tmp_path / "list.txt").write_text("view_00.exr\nnope.png\n")
        kw, where, what = {"test_list": str(tmp_path / "list.txt")}, "list.txt", "test image 'nope.png' is not among"
    elif case == "ns_model":
        root = write_nerfstudio(tmp_path / "ns", PINHOLE, {"camera_model": "EQUIRECTANGULAR"})
        where, what = "transforms.json", "camera_model 'EQUIRECTANGULAR' is not supported"
    elif case == "cfg_source":
        cl.write_3dgs_output(tmp_path / "gs", tmp_path / "moved", [("view_00", W, H, 40.0, 40.0, np.eye(3), [0, 0, 4])])
        root, where, what = tmp_path / "gs", "cfg_args", "is not a folder here"
    with pytest.raises(ptir.Error) as e:
        load(root, split, **kw)
    assert where in str(e.value) and what in str(e.value), str(e.value)


def test_test_list_selects_the_test_views(tmp_path):
    root = write_colmap(tmp_path / "cap", PINHOLE)
    (tmp_path / "list.txt").write_text("# held out\nview_03.exr\nview_05.exr\n")
    assert sorted(load(root, "test", test_list=str(tmp_path / "list.txt")).view_names) == ["view_03", "view_05"]
    assert len(load(root, "train", test_list=str(tmp_path / "list.txt"))) == 8
    assert len(load(root, "train", holdout=0)) == 10


def test_shared_mask_of_a_distorted_capture_is_undistorted_once(tmp_path):
    """nerfstudio mask_path: every frame names one mask; it is resampled with the lens, once."""
    lens = DISTORTED[0]
    root = write_nerfstudio(tmp_path / "ns", lens)
    (root / "masks").mkdir()
    m = np.ones((H, W), np.float32)
    m[:, : W // 2] = 0
    ptir.write_image(str(root / "masks" / "all.png"), m, colour=False)
    d = json.loads((root / "transforms.json").read_text())
    for f in d["frames"]:
        f["mask_path"] = "masks/all.png"
    (root / "transforms.json").write_text(json.dumps(d))
    ds = load(root, "all")
    masks = {ds.files(i)["mask"] for i in range(len(ds))}
    assert len(masks) == 1 and "ptir_undistorted/images/masks/all." in masks.pop()
    rgb, alpha, has_alpha = ds.target(0)
    # The mask's edge (source x = W/2) lands where the image's source x is W/2.
    src_x = rgb[..., 0]
    assert has_alpha
    assert np.all(alpha[src_x < W / 2 - 1] == 0) and np.all(alpha[src_x > W / 2 + 1] == 1)


def test_eval_takes_the_capture_switches(tmp_path):
    """`ptir eval` reads a capture with the same switches as optimize: the hold-out decides the views."""
    src = write_colmap(tmp_path / "cap", PINHOLE)
    write_splat_ply(tmp_path / "g.ply", [[0, 0, 0], [0.2, 0, 0]], [0.3, 0.3, 0.01])
    res = tmp_path / "res"
    r = subprocess.run([str(CLI), "optimize", "--dataset", str(src), "--gaussians", str(tmp_path / "g.ply"), "--out",
                        str(res), "--iters", "1", "--spp", "1", "--bounces", "0", "--threads", "2", "-q", "--fit-iters", "0"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    views = {}
    for holdout in (8, 3):
        r = subprocess.run([str(CLI), "eval", "--dataset", str(src), "--result", str(res), "--holdout", str(holdout),
                            "--spp", "1", "--aov-spp", "1", "--sheet-views", "0", "--threads", "2"],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        views[holdout] = json.loads((res / "eval" / "metrics.json").read_text())["views"]
    # 10 images in name order: every 8th (0, 8) or every 3rd (0, 3, 6, 9) is a test view.
    assert views == {8: 2, 3: 4}, views
