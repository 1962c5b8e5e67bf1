"""The one-click optimise sample that `make demo` writes (sample_blends/make_optimise_sample.py), built
here on a small dataset of the same maker (scripts/make_dataset.py: the sample object by Cycles,
4 views of 32 x 32) and opened in blender -b; optimise_sample_check.py has the checks (dataset path
relative to the .blend, the saved duration estimate, Optimise writes materials back; the estimate
against the run's measured time is printed)."""

import json
import subprocess

import pytest

import addon_common as ac
import blenders

pytestmark = pytest.mark.skipif(not ac.have_blender(), reason="blender not installed")

ITERATIONS = 20


def _blender(version, script, *args):
    cmd = blenders.command(version, script, args)
    env = dict(__import__("os").environ, PTIR_CLI=str(ac.CLI))
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=env)
    assert r.returncode == 0, ac.output_of(r)
    return r


@pytest.mark.parametrize("blender", blenders.params(needs=blenders.v2_needs()))
def test_optimise_sample_in_one_click(blender, tmp_path):
    if not ac.CLI.exists():
        pytest.fail("no CLI at %s (run 'make build' or set PTIR_BUILD_DIR)" % ac.CLI)
    data = tmp_path / "sample_dataset"
    _blender(blender, ac.REPO / "scripts" / "make_dataset.py", "--out", data, "--res", 32, "--train", 4,
             "--test", 1, "--spp", 8, "--subdiv", 0, "--relight-envs", "", "--env-size", "32x16")
    blend = tmp_path / "optimise_sample.blend"
    r = _blender(blender, ac.REPO / "sample_blends" / "make_optimise_sample.py", "--dataset", data, "--out", blend,
                 "--spp", 4)
    assert "make_optimise_sample: estimated" in r.stdout, ac.output_of(r)
    r = ac.run_blender("optimise_sample_check.py", ITERATIONS, blend=blend, timeout=300, blender=blender)
    assert r.returncode == 0 and "ADDON_CHECK: OK" in r.stdout, ac.output_of(r)
    line = next(l for l in r.stdout.splitlines() if l.startswith("SAMPLE_STATS: "))
    print("optimise sample: %s" % json.loads(line[len("SAMPLE_STATS: "):]))
