"""The add-on's PLY layer (addon/ptir_blender/io/splat_ply.py) in plain Python, against the engine.

Activated values are compared with the engine's own loader (the native module)
and with an independent float64 computation: the add-on rounds exp/sigmoid
once to float32, so it equals the float64 reference exactly; glibc's expf that
the engine uses is not correctly rounded, so the engine may differ by 1 ulp.
"""

import math
import sys

import numpy as np
import pytest

import addon_common as ac
from ptir_blender.io import splat_ply as sp
from ptir_blender.io import splat_transform as st

sys.path.insert(0, str(ac.REPO / "tests" / "python"))
import splat_layouts  # noqa: E402


def _check_against_native(d, g, exact_fields=("position", "albedo", "roughness", "metallic")):
    """Equal to the engine's loader: exactly, or within the ulps its float32 libm calls may differ by
    (expf in scale and opacity; quaternions that are already unit are kept as stored by the add-on and
    renormalised by the engine)."""
    for f in exact_fields:
        np.testing.assert_array_equal(getattr(d, f), getattr(g, f), err_msg=f)
    assert ac.ulps(d.scale, g.scale).max() <= 1
    assert ac.ulps(d.opacity, g.opacity).max() <= 2
    assert ac.ulps(d.rotation, g.rotation).max() <= 1


def test_activated_values_equal_engine_and_reference(tmp_path, ptir):
    raw = ac.random_raw(5000, material=True, seed=1)
    path = ac.write_ply(tmp_path / "s.ply", raw)
    d = sp.read_splat_ply(path)
    ref = ac.activated_reference(raw)
    for f in ("position", "scale", "rotation", "opacity"):
        np.testing.assert_array_equal(getattr(d, f), ref[f], err_msg=f)
    g = ptir.load_gaussians(str(path))
    _check_against_native(d, g)
    # SH: f_rest stored channel-major, f_rest_(c*15 + k) -> sh_rest[k, :, c]
    assert d.sh_degree == 3
    np.testing.assert_array_equal(d.sh_rest[4, :, 2], np.float32(raw["f_rest_34"]))
    np.testing.assert_array_equal(d.f_dc[:, 1], np.float32(raw["f_dc_1"]))
    # normals: normalised as the engine does
    np.testing.assert_allclose(d.normal, g.normal, rtol=0, atol=2e-7)
    assert d.has_normals and d.has_material


def test_defaults_when_material_and_normals_are_absent(tmp_path, ptir):
    raw = ac.random_raw(100, sh_rest=0, normals=False, seed=2)
    d = sp.read_splat_ply(ac.write_ply(tmp_path / "s.ply", raw))
    assert d.sh_degree == 0 and not d.has_material and not d.has_normals
    assert np.all(d.albedo == np.float32(0.3)) and np.all(d.roughness == np.float32(0.6)) and np.all(d.metallic == 0)
    assert np.all(d.normal == 0)  # zero: the engine picks the shortest axis
    g = ptir.load_gaussians(str(tmp_path / "s.ply"))
    np.testing.assert_array_equal(d.albedo, g.albedo)
    np.testing.assert_array_equal(d.roughness, g.roughness)


def test_sh_degree_four_reads_as_the_engine_and_round_trips(tmp_path, ptir):
    """72 f_rest (SH degree 4, as Blender 5.3's splats carry it), channel-major, read as the engine reads
    it and written back bit for bit."""
    raw = ac.random_raw(500, sh_rest=72, seed=6)
    path = ac.write_ply(tmp_path / "sh4.ply", raw)
    d = sp.read_splat_ply(path)
    assert d.sh_degree == 4 and d.sh_rest.shape == (24, 500, 3)
    np.testing.assert_array_equal(d.sh_rest[19, :, 2], np.float32(raw["f_rest_%d" % (2 * 24 + 19)]))
    g = ptir.load_gaussians(str(path))
    assert g.sh_degree == 4
    _check_against_native(d, g)
    out = tmp_path / "sh4_out.ply"
    sp.write_splat_ply(out, d)
    np.testing.assert_array_equal(sp.read_splat_ply(out).sh_rest, d.sh_rest)


def test_2dgs_surfels_read_as_the_engine_reads_them(tmp_path, ptir):
    """2D Gaussian Splatting's save_ply: no scale_2 (surfels), normals zero. Both readers make the surfel
    SURFEL_THICKNESS x its smaller scale thick, so its shortest axis is its normal (the rotation's z),
    however elongated (the random log-scales span e^8 = 2981:1)."""
    raw = ac.random_raw(2000, sh_rest=45, normals=False, seed=5)
    del raw["scale_2"]
    path = ac.write_ply(tmp_path / "surfels.ply", raw)
    d = sp.read_splat_ply(path)
    g = ptir.load_gaussians(str(path))
    _check_against_native(d, g)
    small = np.minimum(d.scale[:, 0], d.scale[:, 1])
    np.testing.assert_array_equal(d.scale[:, 2], sp.SURFEL_THICKNESS * small)
    assert np.all(d.scale[:, 2] < d.scale[:, :2].min(axis=1))
    # the engine's shortest-axis normal is the rotation's z axis: R e_z = (2(xz + wy), 2(yz - wx), 1 - 2(x^2 + y^2))
    w, x, y, z = (d.rotation[:, k].astype(np.float64) for k in range(4))
    rz = np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=1)
    np.testing.assert_allclose(np.abs(np.sum(rz * np.asarray(g.normal, np.float64), axis=1)), 1.0, atol=1e-5)


@pytest.mark.parametrize("fmt,types", [("ascii", {}), ("binary_big_endian", {}),
                                       ("binary_little_endian", {"x": "double", "y": "double", "z": "double"}),
                                       ("binary_big_endian", {"opacity": "double", "rot_0": "double"})])
def test_encodings_read_the_same_values(tmp_path, ptir, fmt, types):
    raw = ac.random_raw(300, sh_rest=9, material=True, seed=3)
    names = list(raw)[::-1]  # any property order
    ref = sp.read_splat_ply(ac.write_ply(tmp_path / "ref.ply", raw))
    path = ac.write_ply(tmp_path / "v.ply", raw, names=names, fmt=fmt, types=types)
    d = sp.read_splat_ply(path)
    g = ptir.load_gaussians(str(path))
    if not types:  # same float32 values, only the encoding differs
        for f in sp.SplatData.FIELDS:
            np.testing.assert_array_equal(getattr(d, f), getattr(ref, f), err_msg=f)
    _check_against_native(d, g)


def _encode_compressed(path, raw, n, colour_bounds=True, sh=True):
    """A SuperSplat compressed PLY of the first n splats of raw's positions and scales, with random rotations,
    colours, opacities and (sh) degree-1 SH."""
    rng = np.random.default_rng(5)
    pos = np.stack([raw[c][:n] for c in "xyz"], 1)
    lsc = np.stack([raw["scale_%d" % k][:n] for k in range(3)], 1)
    f_rest = rng.uniform(-3.9, 3.9, size=(n, 9)) if sh else None
    return splat_layouts.write_supersplat_compressed(
        path, pos, lsc, rng.normal(size=(n, 4)), rng.uniform(-1.7, 1.7, size=(n, 3)), rng.uniform(-4, 4, size=n),
        f_rest, colour_bounds=colour_bounds, morton=False)


@pytest.mark.parametrize("colour_bounds,sh", [(True, True), (False, False)])
def test_supersplat_compressed_matches_engine(tmp_path, ptir, colour_bounds, sh):
    raw = ac.random_raw(700, sh_rest=0, seed=4)
    path = _encode_compressed(tmp_path / "c.ply", raw, 700, colour_bounds, sh)
    d = sp.read_splat_ply(path)
    g = ptir.load_gaussians(str(path))
    assert len(d) == 700 and d.sh_degree == (1 if sh else 0)
    _check_against_native(d, g)


@pytest.mark.parametrize("case,expected", [
    ("mesh", "missing properties scale_0, scale_1, scale_2, rot_0, rot_1, rot_2, rot_3, opacity (the file looks "
             "like a triangle mesh)"),
    ("points", "(the file looks like a plain point cloud)"),
    ("no_opacity", "missing properties opacity"),
    ("nan", "property 'scale_1' is NaN at vertex 3"),
    ("rest", "unsupported SH: 7 f_rest_* properties"),
    ("dc", "incomplete property group: missing f_dc_2"),
    ("truncated", "file is truncated"),
    ("not_ply", "not a PLY file"),
    ("zero_quat", "zero-length rotation quaternion"),
])
def test_malformed_files_name_the_problem(tmp_path, case, expected):
    raw = ac.random_raw(10, sh_rest=0, seed=6)
    path = tmp_path / ("%s.ply" % case)
    if case == "mesh":
        path.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                        "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    elif case == "points":
        ac.write_ply(path, {c: raw[c] for c in "xyz"})
    elif case == "no_opacity":
        ac.write_ply(path, {k: v for k, v in raw.items() if k != "opacity"})
    elif case == "nan":
        raw["scale_1"][3] = np.nan
        ac.write_ply(path, raw)
    elif case == "rest":
        raw.update({"f_rest_%d" % i: np.zeros(10) for i in range(7)})
        ac.write_ply(path, raw)
    elif case == "dc":
        ac.write_ply(path, {k: v for k, v in raw.items() if k != "f_dc_2"})
    elif case == "truncated":
        ac.write_ply(path, raw)
        path.write_bytes(path.read_bytes()[:-20])
    elif case == "not_ply":
        path.write_text("hello\n")
    elif case == "zero_quat":
        for k in range(4):
            raw["rot_%d" % k][2] = 0.0
        ac.write_ply(path, raw)
    with pytest.raises(sp.SplatPlyError) as e:
        sp.read_splat_ply(path)
    assert str(path) in str(e.value) and expected in str(e.value), str(e.value)


def test_write_read_round_trip_is_exact(tmp_path, ptir):
    raw = ac.random_raw(20000, material=True, seed=7)
    raw["confidence"] = np.linspace(0, 1, 20000)  # unknown properties survive
    a = sp.read_splat_ply(ac.write_ply(tmp_path / "a.ply", raw))
    sp.write_splat_ply(tmp_path / "b.ply", a)
    b = sp.read_splat_ply(tmp_path / "b.ply")
    for f in sp.SplatData.FIELDS:
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f), err_msg=f)
    np.testing.assert_array_equal(a.extra["confidence"], b.extra["confidence"])
    # the engine reads the written file to the same values
    _check_against_native(b, ptir.load_gaussians(str(tmp_path / "b.ply")))
    # the layout is the standard one, material properties after it
    names = [p[0] for p in sp.read_ply_elements(tmp_path / "b.ply")["__elements__"][0].props]
    assert names[:9] == ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"]
    assert names[-6:] == ["albedo_0", "albedo_1", "albedo_2", "roughness", "metallic", "confidence"]


def _covariance(d):
    r = st.quat_to_matrix(d.rotation)
    return np.einsum("nij,nj,nkj->nik", r, d.scale.astype(np.float64) ** 2, r)


@pytest.mark.parametrize("kind", ["similarity", "mirror", "nonuniform"])
def test_transform_folding_maps_the_gaussians(tmp_path, kind):
    raw = ac.random_raw(500, material=True, seed=8)
    d = sp.read_splat_ply(ac.write_ply(tmp_path / "a.ply", raw))
    c, s = math.cos(0.7), math.sin(0.7)
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.array([[1, 0, 0], [0, c, s], [0, -s, c]])
    a = {"similarity": 2.5 * rot, "mirror": 1.5 * rot @ np.diag([1, -1, 1]),
         "nonuniform": rot @ np.diag([1.0, 2.0, 0.5])}[kind]
    m = np.eye(4)
    m[:3, :3] = a
    m[:3, 3] = (1.0, -2.0, 3.0)
    t = st.transform_splats(d, m)
    np.testing.assert_allclose(t.position, d.position.astype(np.float64) @ a.T + m[:3, 3], rtol=1e-6, atol=1e-5)
    expected = np.einsum("ij,njk,lk->nil", a, _covariance(d), a)
    got = _covariance(t)
    scale = np.max(np.abs(expected), axis=(1, 2), keepdims=True)
    assert np.max(np.abs(got - expected) / scale) < 1e-5
    assert np.allclose(np.linalg.norm(t.rotation, axis=1), 1.0, atol=1e-6)
    n_expected = d.normal.astype(np.float64) @ np.linalg.inv(a)
    n_expected /= np.linalg.norm(n_expected, axis=1, keepdims=True)
    np.testing.assert_allclose(t.normal, n_expected, atol=1e-5)
    for f in ("albedo", "roughness", "metallic", "opacity", "f_dc"):
        np.testing.assert_array_equal(getattr(t, f), getattr(d, f))
    assert st.transform_splats(d, np.eye(4)).rotation is not d.rotation  # a copy, values identical
    np.testing.assert_array_equal(st.transform_splats(d, np.eye(4)).scale, d.scale)


def test_transform_matches_engine_scene_transform(tmp_path, ptir):
    """A similarity folded by the add-on equals the engine's own scene-file transform of the same PLY."""
    raw = ac.random_raw(300, material=True, seed=9)
    path = ac.write_ply(tmp_path / "a.ply", raw)
    c, s = math.cos(0.3), math.sin(0.3)
    m = np.array([[2 * c, -2 * s, 0, 0.5], [2 * s, 2 * c, 0, -1.0], [0, 0, 2, 2.0], [0, 0, 0, 1]])
    t = st.transform_splats(sp.read_splat_ply(path), m)
    scene = ptir.scene_from_dict({"gaussians": [{"file": str(path), "transform": m.tolist()}],
                                  "cameras": [{"transform": np.eye(4).tolist(), "fov_x": 1.0, "width": 4,
                                               "height": 4}]})
    g = scene.gaussians
    np.testing.assert_allclose(t.position, g.position, rtol=1e-6, atol=1e-5)
    np.testing.assert_allclose(t.scale, g.scale, rtol=1e-5)
    same_sign = np.sign(np.sum(t.rotation * g.rotation, axis=1))[:, None]
    np.testing.assert_allclose(t.rotation, g.rotation * same_sign, atol=1e-5)
