"""The Python module `ptir`: loading, AOV layouts and values, hits along a ray, errors."""

import math

import numpy as np
import pytest

from ptir_testing import look_down_minus_z, write_quad_ply, write_splat_ply, write_transforms

# Channels per AOV (the last one is always coverage).
LAYOUT = {"opacity": 1, "depth": 2, "normal": 4, "albedo": 4, "roughness": 2, "metallic": 2, "preview": 4}
FOV = math.radians(40.0)


def camera(ptir, c2w=None, size=33):
    # Odd size: the centre pixel's ray is the optical axis.
    return ptir.Camera(look_down_minus_z() if c2w is None else c2w, FOV, size, size)


def test_load_gaussians_activates_values(ptir, wall_scene):
    f = ptir.load_gaussians(str(wall_scene["ply"]))
    assert len(f) == 81
    assert f.sh_degree == 3
    assert not f.normals_from_file  # nx,ny,nz all zero: trainer output
    assert f.position.shape == (81, 3) and np.allclose(f.position[:, 2], -4.0)
    assert np.allclose(f.scale, [0.075, 0.075, 1.25e-4], rtol=1e-5)
    assert np.allclose(f.opacity, 0.95, atol=1e-6)
    assert np.allclose(f.rotation, [1.0, 0.0, 0.0, 0.0])
    # Shortest axis is z, sign still arbitrary before orientation.
    assert np.allclose(np.abs(f.normal), [0.0, 0.0, 1.0], atol=1e-6)


def test_render_aov_layouts(ptir, wall_scene):
    scene = ptir.Scene(ptir.load_gaussians(str(wall_scene["ply"])), [], 16)
    cam = camera(ptir)
    for aov, channels in LAYOUT.items():
        img = scene.render_aov(cam, aov)
        assert img.dtype == np.float32, aov
        assert img.shape == (33, 33, channels), aov
        cov = img[..., -1]
        assert cov.min() >= 0.0 and cov.max() <= 1.0, aov
        assert cov[16, 16] > 0.9, aov   # the wall fills the centre
        assert np.all(img[0, 0] == 0.0), aov  # the corner sees nothing


def test_wall_values_at_centre(ptir, wall_scene):
    scene = ptir.Scene(ptir.load_gaussians(str(wall_scene["ply"])), [], 16)
    cam = camera(ptir)
    centre = {aov: scene.render_aov(cam, aov)[16, 16] for aov in LAYOUT}
    assert centre["depth"][0] == pytest.approx(4.0, abs=1e-3)
    assert centre["normal"][:3] == pytest.approx([0.0, 0.0, 1.0], abs=1e-3)  # faces the camera
    assert centre["albedo"][:3] == pytest.approx([0.3, 0.3, 0.3], abs=1e-4)  # default material
    assert centre["roughness"][0] == pytest.approx(0.6, abs=1e-4)
    assert centre["metallic"][0] == pytest.approx(0.0, abs=1e-6)
    # Preview: SH colours are display (sRGB) values; they are composited in that
    # space, and the result is stored as linear colour associated with the
    # coverage (docs/alpha.md): the coverage times the decoded straight colour.
    cov = centre["opacity"][0]
    display = np.array([0.8, 0.3, 0.1])
    linear = cov * np.where(display <= 0.04045, display / 12.92, ((display + 0.055) / 1.055) ** 2.4)
    assert centre["preview"][:3] == pytest.approx(linear, abs=0.01)


def test_material_setters_reach_the_render(ptir, wall_scene):
    f = ptir.load_gaussians(str(wall_scene["ply"]))
    f.albedo = np.tile(np.float32([0.2, 0.5, 0.7]), (len(f), 1))
    f.roughness = np.full(len(f), 0.25, np.float32)
    scene = ptir.Scene(f, [], 16)
    cam = camera(ptir)
    assert scene.render_aov(cam, "albedo")[16, 16, :3] == pytest.approx([0.2, 0.5, 0.7], abs=1e-4)
    assert scene.render_aov(cam, "roughness")[16, 16, 0] == pytest.approx(0.25, abs=1e-4)
    with pytest.raises(ptir.Error):
        f.albedo = np.zeros((3, 3), np.float32)  # wrong length


def test_camera_looking_at_nothing_renders_zeros(ptir, wall_scene):
    mesh = ptir.load_mesh(str(wall_scene["mesh"]))
    scene = ptir.Scene(ptir.load_gaussians(str(wall_scene["ply"])), [mesh], 16)
    away = look_down_minus_z()
    away[:3, :3] = np.diag([-1.0, 1.0, -1.0])  # turned around: looks down +z, at empty space
    cam = camera(ptir, away)
    for aov in LAYOUT:
        img = scene.render_aov(cam, aov)
        assert not img.any(), aov
    # The same camera turned back sees the wall, and the mesh behind covers the rest.
    cov = scene.render_aov(camera(ptir), "opacity")[..., 0]
    assert cov.min() > 0.99


def test_single_opaque_gaussian_centre_opacity(ptir, tmp_path):
    ply = write_splat_ply(tmp_path / "one.ply", [(0.0, 0.0, -5.0)], (1.0, 1.0, 0.01), opacity=0.9999)
    scene = ptir.Scene(ptir.load_gaussians(str(ply)), [], 16)
    img = scene.render_aov(camera(ptir), "opacity")
    # Peak response 1, so alpha = min(0.99, sigma) = 0.99 (3DGS clamp).
    assert img[16, 16, 0] == pytest.approx(0.99, abs=1e-3)
    assert img[16, 16, 0] >= img[0, 16, 0] > 0.0  # falls off away from the peak


def test_trace_hits_are_sorted(ptir, tmp_path):
    rng = np.random.default_rng(7)
    depth = np.arange(1, 41, dtype=np.float64)  # 40 Gaussians on the axis: several k = 8 rounds
    order = rng.permutation(len(depth))
    pos = np.column_stack([np.zeros(40), np.zeros(40), -depth[order]])
    ply = write_splat_ply(tmp_path / "line.ply", pos, (0.2, 0.2, 0.05), opacity=0.3)
    field = ptir.load_gaussians(str(ply))
    hits, mesh_t = ptir.Scene(field, [], 8).trace_hits((0, 0, 0), (0, 0, -1))
    assert mesh_t is None
    assert len(hits) == 40
    t = np.array([h[0] for h in hits])
    assert np.all(np.diff(t) > 0)
    assert t == pytest.approx(depth, abs=1e-4)
    assert [h[2] for h in hits] == list(np.argsort(order))  # ids are file order
    assert all(h[1] == pytest.approx(0.3, abs=1e-5) for h in hits)

    # An opaque mesh in the middle ends the walk there.
    mesh = ptir.load_mesh(str(write_quad_ply(tmp_path / "stop.ply", -10.5, 3.0)))
    hits, mesh_t = ptir.Scene(field, [mesh], 8).trace_hits((0, 0, 0), (0, 0, -1))
    assert mesh_t == pytest.approx(10.5, abs=1e-4)
    assert [round(h[0]) for h in hits] == list(range(1, 11))


def test_load_cameras(ptir, tmp_path):
    path = write_transforms(tmp_path / "transforms_test.json", [look_down_minus_z(), look_down_minus_z((1, 2, 3))],
                            fov_x=0.5, size=(64, 48))
    cams = ptir.load_cameras(str(path))
    assert len(cams) == 2
    assert (cams[1].width, cams[1].height) == (64, 48)
    assert cams[1].fov_x == pytest.approx(0.5)
    assert cams[1].name == "test_001"
    origin, direction = cams[1].ray(32.0, 24.0)
    assert origin == pytest.approx((1, 2, 3)) and direction == pytest.approx((0, 0, -1), abs=1e-6)


def test_errors_name_the_problem(ptir, tmp_path):
    missing = tmp_path / "nope.ply"
    with pytest.raises(ptir.Error, match="nope.ply"):
        ptir.load_gaussians(str(missing))
    with pytest.raises(RuntimeError):  # ptir.Error is a RuntimeError
        ptir.load_cameras(str(tmp_path / "none.json"))
    ply = write_splat_ply(tmp_path / "one.ply", [(0.0, 0.0, -5.0)], (1.0, 1.0, 0.01))
    scene = ptir.Scene(ptir.load_gaussians(str(ply)), [], 16)
    with pytest.raises(ptir.Error, match="unknown AOV"):
        scene.render_aov(camera(ptir), "bogus")
    with pytest.raises(ptir.Error):
        ptir.Camera(np.zeros((4, 4), np.float32), FOV, 8, 8)  # degenerate rotation
