"""The add-on in each Blender artists run (Debian's 3.4, bpy 4.5 LTS, bpy 5.0): no deprecation warning from
its code, panels where Cycles' are, EEVEE's engine name of each version, Principled write-back in each
version's model, Blender 5.3's splat attribute names (checks in addon_versions_check.py)."""

import json

import pytest

import addon_common as ac
import blenders


@pytest.mark.parametrize("blender", blenders.params())
def test_addon_fits_each_blender(blender, tmp_path):
    r = ac.run_blender("addon_versions_check.py", tmp_path, blender=blender, timeout=300)
    assert r.returncode == 0 and "ADDON_CHECK: OK" in r.stdout, ac.output_of(r)
    line = next(l for l in r.stdout.splitlines() if l.startswith("VERSIONS_STATS: "))
    stats = json.loads(line[len("VERSIONS_STATS: "):])
    print("Blender %s: %s" % (blender, stats))
    assert stats["blender"].startswith(blender)
    assert stats["model"] == ("principled-v1" if blender == "3.4" else "principled-v2")
    assert stats["scene_brdf"] == ("principled-v1" if blender == "3.4" else "principled-v2")
