"""`ptir serve`, the persistent engine (docs/engine_protocol.md), driven through the add-on's client
(addon/ptir_blender/io/engine_process.py, no Blender): the same pixels as `ptir render`, progressive
passes that add up to the full render, deltas (lights, per-splat materials, mesh materials) with
their expected effect, errors that name the problem and leave the process serving, cancellation."""

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "addon"))
from ptir_blender.io.engine_process import EngineProcess  # noqa: E402

W = H = 24


@pytest.fixture()
def served(cli, wall_scene, tmp_path):
    scene = {
        "gaussians": [{"file": str(wall_scene["ply"])}],
        "meshes": [{"name": "back", "file": str(wall_scene["mesh"]), "material": {"base_color": [0.5, 0.5, 0.5]}}],
        "lights": [{"type": "point", "position": [0.0, 0.0, 0.0], "power": 200.0}],
        "cameras": [{"name": "cam", "transform": np.eye(4).tolist(), "fov_x": 0.9, "width": W, "height": H}],
        "integrator": {"spp": 4, "bounces": 1, "seed": 7},
    }
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    engine = EngineProcess(str(cli), out_dir=str(tmp_path))
    reply = engine.call({"cmd": "load", "scene": str(path)})
    assert reply["gaussians"] == 81 and reply["meshes"] == 1 and reply["lights"] == 1
    yield engine, path, scene
    engine.close()


def render(engine, out, **kw):
    r = engine.call(dict({"cmd": "render", "camera_name": "cam", "output": str(out)}, **kw))
    assert r["ok"], r
    return np.fromfile(out, np.float32).reshape(H, W, 4)


def test_same_pixels_as_ptir_render(served, cli, ptir, tmp_path):
    engine, path, _ = served
    engine.call({"cmd": "render", "camera_name": "cam", "output": str(tmp_path / "serve.exr")})
    subprocess.run([str(cli), "render", str(path), "-o", str(tmp_path / "cli.exr"), "--camera", "cam", "-q"],
                   check=True)
    a, b = (np.asarray(ptir.read_image(str(tmp_path / f))) for f in ("serve.exr", "cli.exr"))
    assert a.shape == (H, W, 4) and a[..., :3].mean() > 0.01
    assert np.abs(a - b).max() == 0.0


def test_progressive_passes_add_up(served, tmp_path):
    engine, _, _ = served
    full = render(engine, tmp_path / "full.raw", spp=4)
    passes = sum(render(engine, tmp_path / ("p%d.raw" % s), spp=1, first_sample=s) for s in range(4))
    assert full[..., :3].mean() > 0.01
    assert np.abs(passes / 4 - full).max() <= 1e-6


def test_deltas(served, tmp_path):
    engine, _, scene = served
    base = render(engine, tmp_path / "a.raw")
    # The only light twice as strong (no environment): every pixel doubles, same random numbers.
    lights = [dict(scene["lights"][0], power=400.0)]
    r = engine.call({"cmd": "update", "scene": {"lights": lights}})
    assert r["changed"] == ["lights"] and r["builds"] == 1
    brighter = render(engine, tmp_path / "b.raw")
    lit = base[..., :3] > 1e-3
    np.testing.assert_allclose(brighter[..., :3][lit] / base[..., :3][lit], 2.0, rtol=1e-4)
    # Per-splat materials: black metal (albedo 0, metallic 1: F0 = 0) on every Gaussian: the wall goes dark.
    f = tmp_path / "mat.f32"
    np.concatenate([np.zeros(81 * 3), np.full(81, 0.5), np.ones(81)]).astype(np.float32).tofile(f)
    r = engine.call({"cmd": "splat_materials", "offset": 0, "count": 81, "file": str(f)})
    assert r["bulk_bytes_in"] == 81 * 20 and r["builds"] == 1
    dark = render(engine, tmp_path / "c.raw")
    centre = (slice(H // 2 - 3, H // 2 + 3), slice(W // 2 - 3, W // 2 + 3))
    assert dark[centre][..., :3].mean() < 0.02 * brighter[centre][..., :3].mean()
    # A mesh material by name.
    engine.call({"cmd": "mesh_material", "mesh": "back", "material": {"base_color": [0.0, 0.0, 0.0]}})
    assert engine.call({"cmd": "status"})["builds"] == 1


def test_partial_splat_materials_equal_the_full_upload(served, tmp_path):
    """One channel, and a subset of the splats by index, change exactly those values: the image equals
    the one after a full upload of the same materials (max difference 0)."""
    engine, _, _ = served
    rng = np.random.default_rng(3)
    albedo, rough, metal = rng.uniform(0.1, 0.9, (81, 3)), rng.uniform(0.2, 0.9, 81), np.zeros(81)
    full = tmp_path / "full.f32"

    def upload(a, r, m):
        np.concatenate([a.reshape(-1), r, m]).astype(np.float32).tofile(full)
        assert engine.call({"cmd": "splat_materials", "offset": 0, "count": 81, "file": str(full)})["ok"]

    upload(albedo, rough, metal)
    before = render(engine, tmp_path / "before.raw")
    sel = np.array([3, 10, 40, 41, 80], np.uint32)
    albedo2, rough2 = albedo.copy(), rough.copy()
    albedo2[sel] = [0.9, 0.05, 0.05]
    rough2[:] = 0.3
    upload(albedo2, rough2, metal)
    expected = render(engine, tmp_path / "expected.raw")
    assert np.abs(expected - before).max() > 0  # the edit shows
    upload(albedo, rough, metal)
    idx, vals = tmp_path / "idx.u32", tmp_path / "vals.f32"
    sel.tofile(idx)
    albedo2[sel].astype(np.float32).tofile(vals)
    r = engine.call({"cmd": "splat_materials", "offset": 0, "count": 81, "channels": ["albedo"], "indices": str(idx),
                     "file": str(vals)})
    assert r["ok"] and r["splats"] == 5 and r["bulk_bytes_in"] == 5 * 4 + 5 * 12, r
    rough2.astype(np.float32).tofile(vals)
    r = engine.call({"cmd": "splat_materials", "offset": 0, "count": 81, "channels": ["roughness"], "file": str(vals)})
    assert r["ok"] and r["bulk_bytes_in"] == 81 * 4 and r["builds"] == 1, r
    assert np.abs(render(engine, tmp_path / "delta.raw") - expected).max() == 0.0
    bad_idx = tmp_path / "bad.u32"
    np.array([81], np.uint32).tofile(bad_idx)
    for request, needle in (({"channels": ["sheen"]}, "unknown channel"), ({"indices": str(bad_idx)}, "bad.u32")):
        r = engine.wait(engine.send(dict({"cmd": "splat_materials", "offset": 0, "count": 81, "file": str(vals)},
                                         **request)))
        assert not r["ok"] and needle in r["error"], r


def test_errors_name_the_problem_and_keep_serving(served, tmp_path):
    engine, _, _ = served
    short = tmp_path / "short.f32"
    np.zeros(10, np.float32).tofile(short)
    cases = [({"cmd": "splat_materials", "offset": 0, "count": 81, "file": str(short)}, str(short)),
             ({"cmd": "update", "scene": {"meshes": []}}, "send \"load\""),
             ({"cmd": "update", "scene": {"lights": [{"type": "point", "power": 1}]}}, "lights[0]"),
             ({"cmd": "load", "scene": str(tmp_path / "missing.json")}, "missing.json"),
             ({"cmd": "mesh_material", "mesh": "nope", "material": {}}, "nope"),
             ({"cmd": "render", "camera_name": "nope", "output": str(tmp_path / "x.raw")}, "nope"),
             ({"cmd": "fly"}, "unknown request")]
    for request, needle in cases:
        r = engine.wait(engine.send(request))
        assert not r["ok"] and needle in r["error"], (request, r)
    engine.proc.stdin.write(b"{not json\n")
    engine.proc.stdin.flush()
    assert engine.alive()
    assert render(engine, tmp_path / "ok.raw")[..., :3].mean() > 0.01  # the scene is intact


def test_cancel_stops_a_long_render(served, tmp_path):
    engine, _, _ = served
    rid = engine.send({"cmd": "render", "camera_name": "cam", "spp": 1 << 20, "output": str(tmp_path / "x.raw")})
    time.sleep(0.3)
    t0 = time.monotonic()
    engine.cancel(rid)
    r = engine.wait(rid, timeout=30)
    assert r.get("cancelled") and time.monotonic() - t0 < 5.0
    assert engine.alive() and render(engine, tmp_path / "after.raw")[..., :3].mean() > 0.01


def test_transform_splats_equals_the_scene_file_transform(served, tmp_path):
    """A move sent as a delta gives the image of a scene file whose gaussians entry has that transform
    (the same transform_gaussians, then a BVH rebuild)."""
    engine, _, scene = served
    m = np.eye(4)
    m[:3, :3] *= 1.5
    m[:3, 3] = (0.3, -0.2, 0.5)
    r = engine.call({"cmd": "transform_splats", "offset": 0, "count": 81, "matrix": m.reshape(-1).tolist()})
    assert r["builds"] == 2
    parts = r["build_parts"]  # where the rebuild went (docs/engine_protocol.md)
    assert set(parts) == {"trace_data_s", "boxes_s", "bvh_s"} and 0 < sum(parts.values()) <= r["build_s"]
    moved = render(engine, tmp_path / "moved.raw")
    other = dict(scene, gaussians=[dict(scene["gaussians"][0], transform=m.tolist())])
    path = tmp_path / "moved.json"
    path.write_text(json.dumps(other))
    engine.call({"cmd": "load", "scene": str(path)})
    reference = render(engine, tmp_path / "reference.raw")
    assert np.abs(moved - reference).max() == 0.0
    skew = np.eye(4)
    skew[0, 1] = 0.5
    r = engine.wait(engine.send({"cmd": "transform_splats", "offset": 0, "count": 81,
                                 "matrix": skew.reshape(-1).tolist()}))
    assert not r["ok"] and "transform_splats" in r["error"]


def test_stale_request_folders_are_removed(tmp_path):
    """Folders of sessions whose Blender is gone (owner.pid not running) go when a new one starts."""
    from ptir_blender.io import engine_process
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale, live = tmp_path / "ptir_engine_a", tmp_path / "ptir_engine_b"
    for folder, pid in ((stale, dead.pid), (live, engine_process.os.getpid())):
        folder.mkdir()
        (folder / "owner.pid").write_text(str(pid))
    engine_process.remove_stale_dirs(str(tmp_path), "ptir_engine_")
    assert not stale.exists() and live.exists()
