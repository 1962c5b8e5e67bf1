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
    assert '"event":"target","stage":"radiance","view":8,"total":8' in r  # the radiance targets' progress


def test_cancelled_make_relightable_leaves_scene_unchanged(dc_only_ply, tmp_path):
    stats, _ = _run("cancel", dc_only_ply, tmp_path)
    assert stats["seconds"] < 90
