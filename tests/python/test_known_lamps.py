"""Known lamps and walls (docs/inversion.md "Known lamps"): a Cycles room (make_dataset.py --room lamps:
the object on a floor before a wall, two coloured area lights, a black world) inverted by `ptir optimize`
with the room's scene file and no environment (--env none), against the set's oracle and a blind run
(environment learnt, no scene file). Needs Blender (skipped without it).

What must hold: with the lamps known the albedo comes out at the right level (per-channel scale gt/ours
within 10 % of 1), where the blind run's learnt light leaves it off by more than that, and far closer to
the oracle's albedo than the blind run; --env none refuses a run with no light to give.
"""

import json

import pytest

from ptir_testing import BLENDER, CLI, REPO, needs_blender, run_checked

pytestmark = needs_blender

RUN = ["--iters", "150", "--spp", "4", "--fit-iters", "0", "--threads", "2", "-q"]


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    if not CLI.exists():
        pytest.fail("no CLI at %s (run 'make build' or set PTIR_BUILD_DIR)" % CLI)
    data = tmp_path_factory.mktemp("room")
    run_checked([*BLENDER, "-P", REPO / "scripts" / "make_dataset.py", "--", "--out", data, "--room", "lamps",
                 "--subdiv", "1", "--textured", "--res", "48", "--train", "12", "--test", "3", "--spp", "32",
                 "--threads", "2"], timeout=600)
    return data


def _eval(room, result, scene=True):
    run_checked([CLI, "eval", "--dataset", room, "--result", result, "--spp", "8", "--aov-spp", "8", "--threads", "2",
                 "-q"] + (["--scene", room / "scene" / "scene.json"] if scene else []), timeout=600)
    return json.loads((result / "eval" / "metrics.json").read_text())


def test_room_dataset_records_its_scene(room):
    meta = json.loads((room / "dataset.json").read_text())
    assert meta["scene"] == "scene/scene.json" and meta["train_env"] is None and meta["relight_envs"] == []
    scene = json.loads((room / "scene" / "scene.json").read_text())
    assert [m["name"] for m in scene["meshes"]] == ["floor", "wall"]
    assert [(l["type"], l["power"]) for l in scene["lights"]] == [("area", 260.0), ("area", 140.0)]
    assert "environment" not in scene


def test_known_lamps_recover_the_albedo_level(room, tmp_path):
    oracle = _eval(room, room / "oracle")
    known, blind = tmp_path / "known", tmp_path / "blind"
    run_checked([CLI, "optimize", "--dataset", room, "--gaussians", room / "gaussians.ply", "--out", known,
                 "--scene", room / "scene" / "scene.json", "--env", "none", *RUN], timeout=900)
    run_checked([CLI, "optimize", "--dataset", room, "--gaussians", room / "gaussians.ply", "--out", blind, *RUN],
                timeout=900)
    mk, mb = _eval(room, known), _eval(room, blind, scene=False)
    print("albedo dB: oracle %.2f, lamps known %.2f, blind %.2f; scale known %s, blind %s" % (
        oracle["albedo_psnr"], mk["albedo_psnr"], mb["albedo_psnr"], mk["albedo_scale"], mb["albedo_scale"]))
    assert all(abs(s - 1.0) < 0.10 for s in mk["albedo_scale"]), mk["albedo_scale"]
    assert any(abs(s - 1.0) > 0.10 for s in mb["albedo_scale"]), mb["albedo_scale"]
    assert mk["albedo_psnr"] > mb["albedo_psnr"] + 5.0
    assert mk["albedo_psnr"] > oracle["albedo_psnr"] - 12.0  # short run (150 x 4 at 48 px); docs/known_lamps.md


def test_lamps_with_a_learnt_environment_start_it_dark(room, tmp_path):
    # The scene's lamps and a learnt environment: the environment starts dark and the albedos learn at
    # once (optimizer_setup.h, kSceneLitEnvStart), so the environment does not take the lamps' light.
    out = tmp_path / "both"
    run_checked([CLI, "optimize", "--dataset", room, "--gaussians", room / "gaussians.ply", "--out", out,
                 "--scene", room / "scene" / "scene.json", *RUN], timeout=900)
    settings = json.loads((out / "settings.json").read_text())
    model, size, start = settings["env"].split()
    assert (model, size) == ("latlong", "128x64") and abs(float(start) - 0.02) < 1e-6, settings["env"]
    assert settings["warmup"].split()[0] == "0", settings["warmup"]
    m = _eval(room, out)
    print("albedo dB, lamps known + environment learnt: %.2f, scale %s" % (m["albedo_psnr"], m["albedo_scale"]))
    assert all(abs(s - 1.0) < 0.15 for s in m["albedo_scale"]), m["albedo_scale"]


def test_env_none_needs_scene_light(room, tmp_path):
    cmd = [CLI, "optimize", "--dataset", room, "--gaussians", room / "gaussians.ply", "--iters", "1", "--spp", "1",
           "--fit-iters", "0", "-q", "--env", "none"]
    import subprocess
    r = subprocess.run([str(c) for c in cmd + ["--out", tmp_path / "a"]], capture_output=True, text=True, timeout=120)
    assert r.returncode != 0 and "--env none" in r.stderr and "--scene" in r.stderr, r.stderr
    unlit = tmp_path / "unlit.json"
    scene = json.loads((room / "scene" / "scene.json").read_text())
    scene.pop("lights")
    for m in scene["meshes"]:
        m["file"] = str(room / "scene" / m["file"])
    unlit.write_text(json.dumps(scene))
    r = subprocess.run([str(c) for c in cmd + ["--out", tmp_path / "b", "--scene", unlit]], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode != 0 and "unlit.json" in r.stderr and "it has none" in r.stderr, r.stderr
    r = subprocess.run([str(c) for c in cmd + ["--out", tmp_path / "c", "--scene", room / "scene" / "scene.json",
                                               "--env-init", room / "oracle" / "env.exr"]],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode != 0 and "--env-init needs an environment model" in r.stderr, r.stderr
