"""Material editing on splats in blender -b (checks in addon_edit_check.py); the effect of an edit
on a render, indirect light included, is checked in test_addon_render.py."""

import pytest

import addon_common as ac
import blenders

pytestmark = pytest.mark.skipif(not ac.have_blender(), reason="blender not installed")


@pytest.mark.parametrize("blender", blenders.params())
def test_edit_material_on_selection_group_and_all(blender, tmp_path):
    raw = ac.random_raw(300, material=True, seed=21)
    ply = ac.write_ply(tmp_path / "s.ply", raw)
    r = ac.run_blender("addon_edit_check.py", ply, blender=blender)
    assert r.returncode == 0 and "ADDON_CHECK: OK" in r.stdout, ac.output_of(r)
