"""The add-on's engine client (addon/ptir_blender/io/engine_client.py) and its io/ package without Blender:
every io/ module imports in a Python where Blender's modules cannot be imported; the command lines it
builds are the ones the engine parses; a one-off job run to its end reports the engine's own error."""

import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "addon"))
from ptir_blender.io import engine_client  # noqa: E402

BLOCK_BLENDER = """
import importlib.abc, sys
class Block(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("bpy", "mathutils", "gpu", "bpy_extras", "bmesh", "blf"):
            raise ImportError("Blender module " + name + " imported by io/")
sys.meta_path.insert(0, Block())
sys.path.insert(0, %r)
import pkgutil, importlib, ptir_blender.io as io
names = [m.name for m in pkgutil.iter_modules(io.__path__)]
for n in names:
    importlib.import_module("ptir_blender.io." + n)
print(len(names))
"""


def test_io_imports_without_blender():
    # Every io/ module, imported where bpy & co raise ImportError (the add-on's own
    # guard makes the package importable; io/ must not need them at all).
    out = subprocess.run([sys.executable, "-c", BLOCK_BLENDER % str(REPO / "addon")], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert int(out.stdout.strip()) >= 15


def _settings(**kw):
    s = dict(spp=16, bounces=2, seed=3, env="latlong", env_width=128, env_height=64, iterations=200,
             views_per_iter=1, crop=0, learn_exposure=False, optimize_metallic=False, threads=0, fit_iterations=500,
             preset="CUSTOM", interaction="aggregate", tau_g=0.5)
    s.update(kw)
    return SimpleNamespace(**s)


def test_optimize_command_lines():
    s = _settings(optimize_metallic=True, threads=2)
    args = engine_client.optimize_args("ptir", s, "/d", "train", "/g.ply", "/out", fitted=False, budget=0.0,
                                       scene_json="/s.json", optimize_meshes=True)
    assert args == ["ptir", "optimize", "--dataset", "/d", "--split", "train", "--gaussians", "/g.ply", "--out", "/out",
                    "--bounces", "2", "--env", "latlong", "--env-size", "128x64", "--seed", "3", "--fit-iters", "0",
                    "--indirect", "path", "--iters", "200", "--spp", "16", "--views-per-iter", "1", "--crop", "0",
                    "--scene", "/s.json", "--optimize-meshes", "--progress", "json", "--optimize-metallic", "--threads",
                    "2"]
    # A time preset: the fit takes FIT_SHARE of it, the inversion the rest (then what is left).
    budget = engine_client.preset_seconds(_settings(preset="DRAFT"))
    assert budget == 120.0
    fit = engine_client.fit_args("ptir", s, "/d", "train", "/g.ply", "/out/fit", budget)
    assert fit[fit.index("--budget") + 1] == "48s" and fit[fit.index("--progress") + 1] == "json"
    inv = engine_client.optimize_args("ptir", s, "/d", "train", "/out/fit/gaussians.ply", "/out", True, budget, None,
                                      False)
    assert inv[inv.index("--budget") + 1] == "72s" and inv[inv.index("--indirect") + 1] == "field"
    assert engine_client.inversion_args(inv, budget, True, 30.0)[inv.index("--budget") + 1] == "90s"
    assert engine_client.inversion_args(inv, budget, True, 115.0)[inv.index("--budget") + 1] == "10s"
    only = engine_client.splats_only_args("ptir", s, "/g.ply", "/out", own_defaults=True)
    assert "--iters" not in only and only[:4] == ["ptir", "optimize", "--gaussians", "/g.ply"]
    assert engine_client.relightable_overrides(50, 0, 12, 0) == ["--iters", "50", "--orbit-views", "12"]
    # The estimate's probes: the inversion on the fit's input; a few fit iterations into a scratch folder.
    est = engine_client.estimate_args(inv, fit)
    assert est[-1] == "--estimate" and est[est.index("--gaussians") + 1] == "/g.ply"
    probe = engine_client.fit_probe_args(fit, "/scratch", 8)
    assert probe[probe.index("--out") + 1] == "/scratch" and probe[probe.index("--iters") + 1] == "8"
    assert probe[-4:] == ["--checkpoint-every", "0", "-q", "--force"] and fit[fit.index("--iters") + 1] == "500"


def test_the_engine_parses_the_command_lines(cli, tmp_path):
    # `ptir <command> ... --help` parses every option before printing the help: an
    # unknown or malformed option fails (CLI11 reports it).
    s = _settings(threads=1)
    for args in (engine_client.optimize_args(str(cli), s, str(tmp_path), "train", "g.ply", str(tmp_path / "o"),
                                             False, 0.0, None, False),
                 engine_client.fit_args(str(cli), s, str(tmp_path), "train", "g.ply", str(tmp_path / "f"), 120.0),
                 engine_client.render_args(str(cli), "s.json", "o.exr", "Camera", s)):
        job = engine_client.run_to_end(args + ["--help"])
        assert job.proc.returncode == 0, (args, job.error_message())
    bad = engine_client.run_to_end(engine_client.fit_args(str(cli), s, "d", "train", "g.ply", "f", 0.0) + ["--nope"])
    assert bad.proc.returncode != 0 and "--nope" in bad.error_message() + " ".join(bad.lines)


def test_run_to_end_reports_the_engine_error(cli, tmp_path):
    missing = tmp_path / "missing.json"
    job = engine_client.run_to_end([str(cli), "render", str(missing), "-o", str(tmp_path / "o.exr")])
    assert job.proc.returncode != 0
    assert "missing.json" in job.error_message()
    assert not os.path.exists(tmp_path / "o.exr")


def test_requests():
    assert engine_client.splat_materials_request(4, 10, "/m.f32", channels=["albedo"], indices="/i.u32") == {
        "cmd": "splat_materials", "offset": 4, "count": 10, "channels": ["albedo"], "file": "/m.f32",
        "indices": "/i.u32"}
    assert engine_client.transform_splats_request(0, 2, range(16))["matrix"][15] == 15.0
    assert engine_client.render_progress_text("L", 0.25, 2.0) == "L | 25%, 2.0 s elapsed, ETA 6.0 s"
