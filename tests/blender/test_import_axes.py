"""Import options: Forward / Up axes and scale (glTF-importer style) become the object's matrix."""

import pytest

import addon_common as ac
import blenders

pytestmark = pytest.mark.skipif(not ac.have_blender(), reason="needs blender")


@pytest.mark.parametrize("blender", blenders.params())
def test_import_axes_and_scale(blender, tmp_path):
    ply = tmp_path / "yup.ply"
    ac.write_ply(ply, ac.random_raw(50, sh_rest=0))
    r = ac.run_blender("import_axes_check.py", ply, blender=blender)
    assert r.returncode == 0 and "ADDON_CHECK: OK" in r.stdout, ac.output_of(r)
