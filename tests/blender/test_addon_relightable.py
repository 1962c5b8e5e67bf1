"""bpy.ops.ptir.make_relightable in blender -b on a splat PLY with the DC colour only, as other tools
write them (checks in addon_relightable_check.py): no dataset, the materials come from the splats' own
radiance. The splats: 400 flat Gaussians on a sphere, DC colour (0.8, 0.4, 0.15), no f_rest, no normals.
8 virtual views of 64 x 64 and 40 iterations at 4 spp take seconds.
"""

import sys

import numpy as np
import pytest

import addon_common as ac
import blenders

sys.path.insert(0, str(ac.REPO / "tests" / "python"))
import ptir_testing as pt  # noqa: E402

pytestmark = pytest.mark.skipif(not ac.have_blender(), reason="blender not installed")


@pytest.fixture(scope="module")
def dc_only_ply(tmp_path_factory):
    if not ac.CLI.exists():
        pytest.fail("no CLI at %s (run 'make build' or set PTIR_BUILD_DIR)" % ac.CLI)
    n = 400
    normals = np.array(pt.fibonacci_sphere(n), np.float64)
    quats = pt.quat_z_to(normals)
    sigma = np.tile([0.12, 0.12, 0.002], (n, 1))
    path = tmp_path_factory.mktemp("dc_only") / "other_tool.ply"
    pt.write_splat_ply(str(path), normals, sigma, quat=quats, opacity=0.95, colour=(0.8, 0.4, 0.15), sh_rest=0)
    return str(path)


def _run(mode, ply, tmp_path, iterations=40, blender="3.4"):
    return ac.blender_result("addon_relightable_check.py", "RELIGHTABLE_STATS", mode, ply, tmp_path, iterations,
                             blender=blender, with_output=True)


@pytest.mark.parametrize("blender", blenders.params(needs=blenders.v2_needs()))
def test_make_relightable_without_photos(blender, dc_only_ply, tmp_path):
    stats, r = _run("finish", dc_only_ply, tmp_path, blender=blender)
    print("make relightable: %s" % stats)
    assert "roughness and metallic are unconstrained" in r  # SH degree 0, said by the engine
    assert "radiance: view 8/8 rendered" in r


def test_cancelled_make_relightable_leaves_scene_unchanged(dc_only_ply, tmp_path):
    stats, _ = _run("cancel", dc_only_ply, tmp_path)
    assert stats["seconds"] < 90


@pytest.mark.parametrize("layout", ["inria_sh3", "sh0", "supersplat"])
def test_ply_layouts_give_materials(layout, dc_only_ply, tmp_path):
    """The PLY layouts the project reads (INRIA SH degree 3, DC only as Mip-Splatting exports, SuperSplat
    compressed) through `ptir optimize` without --dataset in a quick setting: finite, non-trivial
    materials (the albedo left its start of 0.3 and varies across the splats, or follows the colours)."""
    import subprocess
    from test_addon_splat_ply import _encode_compressed
    from ptir_blender.io import splat_ply as sp
    if layout == "supersplat":
        ply = _encode_compressed(tmp_path / "compressed.ply", ac.random_raw(700, sh_rest=0, seed=4), 700)
    elif layout == "inria_sh3":
        n = 400
        normals = np.array(pt.fibonacci_sphere(n), np.float64)
        ply = pt.write_splat_ply(tmp_path / "sh3.ply", normals, np.tile([0.12, 0.12, 0.002], (n, 1)),
                                 quat=pt.quat_z_to(normals), colour=np.where(normals[:, 2:3] > 0, [[0.8, 0.4, 0.15]],
                                                                               [[0.2, 0.5, 0.7]]), sh_rest=45)
    else:
        ply = dc_only_ply
    out = tmp_path / "out"
    r = subprocess.run([str(ac.CLI), "optimize", "--gaussians", str(ply), "--out", str(out), "--iters", "20", "--spp", "2",
                        "--orbit-views", "6", "--orbit-size", "32", "--env-size", "16x8", "--threads", "2"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    d = sp.read_splat_ply(str(out / "gaussians.ply"))
    assert np.all(np.isfinite(d.albedo)) and np.all(np.isfinite(d.roughness))
    # Non-trivial: 20 steps move the albedo off its start (0.3) and apart across differently coloured splats
    # (measured: mean |albedo - 0.3| 0.02 (SH3), 0.08 (compressed); std 0.03 and 0.012).
    assert np.abs(d.albedo - 0.3).mean() > 0.02, d.albedo.mean(0)
    if layout != "sh0":  # two colours (SH3 sphere), random colours (compressed); the DC-only sphere is one
        assert d.albedo.std(0).max() > 0.01, d.albedo.std(0)
    print(layout, "albedo mean", d.albedo.mean(0), "std", d.albedo.std(0), "roughness", d.roughness.mean())
