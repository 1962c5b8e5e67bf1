"""Material edits sent to the persistent engine as deltas equal a fresh load (material_delta_check.py)."""

import json

import pytest

import addon_common as ac
import blenders

pytestmark = pytest.mark.skipif(not ac.have_blender(), reason="blender not installed")


@pytest.mark.parametrize("blender", blenders.params(needs=blenders.v2_needs()))
def test_material_edit_deltas_equal_a_fresh_load(blender, tmp_path):
    if not ac.CLI.exists():
        pytest.fail("no CLI at %s (run 'make build' or set PTIR_BUILD_DIR)" % ac.CLI)
    r = ac.run_blender("material_delta_check.py", tmp_path, blend=ac.REPO / "sample_blends" / "cornell_splats.blend",
                       timeout=300, blender=blender)
    assert r.returncode == 0 and "ADDON_CHECK: OK" in r.stdout, ac.output_of(r)
    line = next(l for l in r.stdout.splitlines() if l.startswith("DELTA_STATS: "))
    print("material deltas: %s" % json.loads(line[len("DELTA_STATS: "):]))
