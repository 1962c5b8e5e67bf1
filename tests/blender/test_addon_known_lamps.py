"""The add-on's "scene lights only" path (Optimise panel: Environment None) on a Cycles room made by the same
Blender (make_dataset.py --room lamps: the object on a floor before a wall, two coloured area lights, a
black world; the room saved as a .blend). Blender imports the object's splats in place of its meshes and
optimises them from the dataset folder with the lamps and walls as known light (checks in
addon_known_lamps_check.py); `ptir eval` then scores the result against the set's truth, beside a blind
run (lamps hidden, environment learnt). The lamps known must bring the albedo's level to within 15 % per
channel of the truth, which the blind run misses, and a far better albedo PSNR.
"""

import json
import subprocess

import pytest

import addon_common as ac
import blenders

pytestmark = pytest.mark.skipif(not ac.have_blender(), reason="blender not installed")

ITERATIONS = 150


def _blender(version, script, *args):
    cmd = blenders.command(version, script, args)
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, ac.output_of(r)
    return r


def _optimise(blender, mode, data, blend, work):
    r = ac.run_blender("addon_known_lamps_check.py", mode, data, work, ITERATIONS, blend=blend, timeout=900,
                       blender=blender)
    assert r.returncode == 0 and "ADDON_CHECK: OK" in r.stdout, ac.output_of(r)
    line = next(l for l in r.stdout.splitlines() if l.startswith("LAMPS_STATS: "))
    return json.loads(line[len("LAMPS_STATS: "):])


def _albedo(data, out):
    r = subprocess.run([str(ac.CLI), "eval", "--dataset", str(data), "--result", out, "--spp", "4", "--aov-spp", "8",
                        "--threads", "2", "-q"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    m = json.load(open(out + "/eval/metrics.json"))
    return m["albedo_psnr"], m["albedo_scale"]


@pytest.mark.parametrize("blender", blenders.params(needs=blenders.v2_needs()))
def test_optimise_with_scene_lights(blender, tmp_path):
    if not ac.CLI.exists():
        pytest.fail("no CLI at %s (run 'make build' or set PTIR_BUILD_DIR)" % ac.CLI)
    data, blend = tmp_path / "room", tmp_path / "room.blend"
    _blender(blender, ac.REPO / "scripts" / "make_dataset.py", "--out", data, "--room", "lamps", "--subdiv", 1,
             "--textured", "--res", 48, "--train", 12, "--test", 3, "--spp", 32, "--threads", 2, "--save-blend", blend)
    _optimise(blender, "unlit", data, blend, tmp_path / "unlit")
    known = _optimise(blender, "known", data, blend, tmp_path / "known")
    assert known["settings"]["env"] == "none" and known["settings"]["lights"] == "2" \
        and known["settings"]["meshes"] == "2" and known["settings"]["mesh_materials"] == "fixed", known["settings"]
    blind = _optimise(blender, "blind", data, blend, tmp_path / "blind")
    assert blind["settings"]["lights"] == "0" and blind["settings"]["env"].startswith("latlong"), blind["settings"]
    psnr_known, scale_known = _albedo(data, known["out"])
    psnr_blind, scale_blind = _albedo(data, blind["out"])
    print("Blender %s: albedo lamps known %.2f dB, scale %s; blind %.2f dB, scale %s"
          % (blender, psnr_known, scale_known, psnr_blind, scale_blind))
    assert all(abs(s - 1.0) < 0.15 for s in scale_known), scale_known
    assert any(abs(s - 1.0) > 0.15 for s in scale_blind), scale_blind
    assert psnr_known > psnr_blind + 5.0
