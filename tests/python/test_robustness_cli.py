"""Nothing lost under any input (issue #40; docs/robustness.md), through the real CLI:

- parsers with bounds: deep JSON nesting, numbers that overflow, out-of-range lengths, special files
  (/dev/zero, a FIFO) refused at once with messages naming the file and the field;
- outputs that cannot lose data: a full disk (a 1 MiB tmpfs) fails the command with status 1, no
  "wrote", the old file intact; a failed optimize leaves the previous result and checkpoint as they were;
- no output among a dataset's files (`cameras -o DATASET/transforms.json`, `optimize --out DATASET/images`);
- datasets checked whole: COLMAP / nerfstudio duplicates and trailing junk refused naming the file and
  entry; a corrupt photo found before the first iteration (no checkpoint written).
"""

import json
import os
import shutil
import subprocess
import time

import numpy as np
import pytest

from ptir_testing import look_down_minus_z, write_splat_ply, write_transforms
from test_optimize_cli import dataset  # noqa: F401  (the module's dataset fixture)


def run(cli, *args, timeout=120):
    return subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True, timeout=timeout)


@pytest.fixture()
def wall(tmp_path):
    g = np.linspace(-0.5, 0.5, 9)
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    pos = np.column_stack([xy, np.full(len(xy), -4.0)])
    ply = write_splat_ply(tmp_path / "wall.ply", pos, (0.07, 0.07, 1e-4), colour=(0.8, 0.3, 0.1))
    scene = {"gaussians": [{"file": "wall.ply"}],
             "lights": [{"type": "point", "position": [0, 0, 0], "power": 100.0}],
             "cameras": [{"name": "front", "transform": look_down_minus_z().tolist(), "fov_x": 0.7,
                          "width": 24, "height": 16}],
             "integrator": {"spp": 1, "bounces": 1}}
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    return {"ply": ply, "scene": path, "doc": scene, "dir": tmp_path}


def render_scene(cli, wall, doc, out):
    p = wall["dir"] / "variant.json"
    p.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    return p, run(cli, "render", p, "-o", out, "-q")


# --- parsers with bounds ---------------------------------------------------------------------------------

def test_deep_json_nesting_is_an_error_not_a_crash(cli, wall, tmp_path):
    doc = '{"comment": ' + "[" * 60000 + "]" * 60000 + "}"
    p, r = render_scene(cli, wall, doc, tmp_path / "o.exr")
    assert r.returncode == 1, (r.returncode, r.stderr[-500:])  # was SIGSEGV
    assert str(p) in r.stderr and "nested deeper" in r.stderr


def test_number_overflow_names_the_file(cli, wall, tmp_path):
    doc = json.dumps(wall["doc"]).replace('"power": 100.0', '"power": 1e400')
    p, r = render_scene(cli, wall, doc, tmp_path / "o.exr")
    assert r.returncode == 1 and str(p) in r.stderr and "1e400" in r.stderr, r.stderr


@pytest.mark.parametrize("field,value", [("fixed_offset", 1e30), ("fixed_range", 1e30), ("filter_width", 1e9),
                                         ("min_throughput", 1e30)])
def test_lengths_out_of_range_are_refused_before_embree(cli, wall, tmp_path, field, value):
    doc = dict(wall["doc"], integrator=dict(wall["doc"]["integrator"], self_intersection="fixed",
                                            **{field: value}))
    p, r = render_scene(cli, wall, doc, tmp_path / "o.exr")
    assert r.returncode == 1, (r.returncode, r.stderr[-500:])  # fixed_offset 1e30 was an Embree abort
    assert str(p) in r.stderr and "integrator." + field in r.stderr


def test_special_files_are_refused_at_once(cli, wall, tmp_path):
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    cases = [("/dev/zero", "/dev/zero"), (fifo, str(fifo))]
    for scene, needle in cases:
        t0 = time.monotonic()
        r = run(cli, "render", scene, "-o", tmp_path / "o.exr", "-q", timeout=20)
        assert r.returncode == 1 and needle in r.stderr and "not a regular file" in r.stderr, r.stderr
        assert time.monotonic() - t0 < 10
    # ... and as files a scene names: a PLY, an environment map.
    for key, doc in (("gaussians", dict(wall["doc"], gaussians=[{"file": "/dev/zero"}])),
                     ("environment", dict(wall["doc"], environment={"type": "latlong", "file": str(fifo)}))):
        t0 = time.monotonic()
        p, r = render_scene(cli, wall, doc, tmp_path / "o.exr")
        assert r.returncode == 1 and "not a regular file" in r.stderr, (key, r.stderr)
        assert time.monotonic() - t0 < 10


# --- full disks --------------------------------------------------------------------------------------------

@pytest.fixture()
def small_fs(tmp_path):
    """A 1 MiB tmpfs (root only); skipped, with the reason, where mounting is not permitted."""
    d = tmp_path / "small"
    d.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(d)], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip("cannot mount a small tmpfs here (%s): the ENOSPC tests need root" % r.stderr.strip())
    try:
        yield d
    finally:
        subprocess.run(["umount", "-l", str(d)])


def fill(folder, leave=0):
    """Fills the file system of `folder`, leaving about `leave` bytes."""
    st = os.statvfs(folder)
    free = st.f_bavail * st.f_frsize - leave
    with open(folder / "filler", "wb") as f:
        try:
            f.write(b"\0" * max(0, free))
            f.flush()
            os.fsync(f.fileno())
        except OSError:
            pass


@pytest.mark.parametrize("ext", ["png", "exr"])
def test_render_on_a_full_disk_keeps_the_old_file(cli, wall, small_fs, ext):
    old = small_fs / ("old." + ext)
    r = run(cli, "render", wall["scene"], "-o", old, "--width", 96, "--height", 64)
    assert r.returncode == 0, r.stderr
    before = old.read_bytes()
    fill(small_fs)
    r = run(cli, "render", wall["scene"], "-o", old, "--width", 96, "--height", 64, "--spp", 2)
    assert r.returncode == 1, (r.returncode, r.stderr)  # PNG was exit 0, "wrote", and a 0-byte file
    assert "wrote" not in r.stdout + r.stderr and str(old) in r.stderr
    assert old.read_bytes() == before
    assert sorted(p.name for p in small_fs.iterdir()) == ["filler", old.name]  # no temp left


def test_serve_on_a_full_disk_answers_an_error(cli, wall, small_fs):
    from test_serve_hardening import Raw
    old = small_fs / "old.exr"
    e = Raw(cli, out=small_fs)
    assert e.call({"cmd": "load", "scene": str(wall["scene"])})["ok"]
    assert e.call({"cmd": "render", "camera_name": "front", "output": str(old), "width": 96, "height": 64})["ok"]
    before = old.read_bytes()
    fill(small_fs)
    for out in (old, small_fs / "new.raw"):
        r = e.call({"cmd": "render", "camera_name": "front", "output": str(out), "width": 96, "height": 64, "id": 5})
        assert not r["ok"] and r["id"] == 5 and str(out) in r["error"], r
    assert old.read_bytes() == before and not (small_fs / "new.raw").exists()
    assert e.close() == 0


def test_a_failed_optimize_leaves_the_previous_result(cli, dataset, small_fs):  # noqa: F811
    out = small_fs / "out"
    base = [str(cli), "optimize", "--dataset", str(dataset), "--gaussians", str(dataset / "g.ply"), "--out", str(out),
            "--spp", "1", "--threads", "1", "--env-size", "16x8", "--fit-iters", "0", "-q"]
    r = subprocess.run(base + ["--iters", "1"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert "checkpoint.bin" in before and "gaussians.ply" in before
    # Room for one new checkpoint, not for the result: the run fails part-way through its writes.
    fill(small_fs, leave=len(before["checkpoint.bin"]) + 16384)
    r = subprocess.run(base + ["--iters", "3", "--checkpoint-every", "1", "--seed", "5"], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 1, r.stderr[-2000:]
    after = {p.name: p.read_bytes() for p in out.iterdir()}
    assert after.keys() == before.keys(), sorted(after)
    assert all(after[k] == before[k] for k in before), [k for k in before if after[k] != before[k]]


# --- no output among a dataset's files ---------------------------------------------------------------------

def colmap_text_dataset(ptir, folder, cameras_txt=None, images_txt=None):
    model = folder / "sparse" / "0"
    model.mkdir(parents=True)
    (folder / "images").mkdir()
    for name in ("a.png", "b.png"):
        ptir.write_image(str(folder / "images" / name), np.full((6, 8, 3), 0.5, np.float32))
    (model / "cameras.txt").write_text(cameras_txt or "1 PINHOLE 8 6 10 10 4 3\n")
    (model / "images.txt").write_text(images_txt or
                                      "1 1 0 0 0 0 0 0 1 a.png\n\n2 1 0 0 0 0.5 0 0 1 b.png\n\n")
    (model / "points3D.txt").write_text("")
    return folder


def test_cameras_never_writes_over_a_datasets_files(cli, ptir, tmp_path):
    ds = colmap_text_dataset(ptir, tmp_path / "colmap")
    nerf = tmp_path / "nerf"
    nerf.mkdir()
    write_transforms(nerf / "transforms.json", [look_down_minus_z()])
    for folder, target in ((ds, ds / "sparse" / "0" / "cameras.txt"), (ds, ds / "sparse" / "0" / "images.txt"),
                           (ds, ds / "cams.json"), (nerf, nerf / "transforms.json")):
        before = target.read_bytes() if target.exists() else None
        r = run(cli, "cameras", "--dataset", folder, "-o", target)
        assert r.returncode == 1 and "dataset" in r.stderr and str(target) in r.stderr, r.stderr
        assert (target.read_bytes() if target.exists() else None) == before
    assert run(cli, "cameras", "--dataset", ds, "-o", tmp_path / "cams.json").returncode == 0


def test_optimize_refuses_an_out_folder_among_the_photos(cli, dataset, tmp_path):  # noqa: F811
    for sub in ("train_000", "train_000/new"):
        r = run(cli, "optimize", "--dataset", dataset, "--gaussians", dataset / "g.ply", "--out", dataset / sub,
                "--iters", 1, "--spp", 1, "--threads", 1, "--env-size", "16x8", "-q")
        assert r.returncode == 1 and "dataset" in r.stderr and "--force" in r.stderr, r.stderr
    assert sorted(p.name for p in (dataset / "train_000").iterdir()) == ["rgba.png"]


# --- datasets checked whole ----------------------------------------------------------------------------------

@pytest.mark.parametrize("cameras_txt,images_txt,needle", [
    ("1 PINHOLE 8 6 10 10 4 3\n1 PINHOLE 8 6 11 11 4 3\n", None, "camera id 1 appears twice"),
    ("1 PINHOLE 8 6 10 10 4 3 junk\n", None, "junk"),
    (None, "1 1 0 0 0 0 0 0 1 a.png\n\n1 1 0 0 0 0.5 0 0 1 b.png\n\n", "image id 1 appears twice"),
    (None, "1 1 0 0 0 0 0 0 1 a.png\n\n2 1 0 0 0 0.5 0 0 1 a.png\n\n", "'a.png' appears twice"),
    (None, "1 0 0 0 0 0 0 0 1 a.png\n\n", "quaternion"),
])
def test_colmap_text_models_refuse_duplicates_and_junk(cli, ptir, tmp_path, cameras_txt, images_txt, needle):
    ds = colmap_text_dataset(ptir, tmp_path / "ds", cameras_txt, images_txt)
    r = run(cli, "cameras", "--dataset", ds, "-o", tmp_path / "c.json")
    assert r.returncode == 1 and needle in r.stderr and "sparse/0/" in r.stderr, r.stderr


def test_photos_smaller_than_their_camera_are_refused(cli, ptir, tmp_path):
    ds = colmap_text_dataset(ptir, tmp_path / "ds", cameras_txt="1 PINHOLE 16 12 20 20 8 6\n")  # photos are 8x6
    r = run(cli, "cameras", "--dataset", ds, "-o", tmp_path / "c.json")
    assert r.returncode == 1 and "smaller than its camera" in r.stderr and "a.png" in r.stderr, r.stderr
    assert "--images" in r.stderr
    # A downscaled folder chosen by name is read, its intrinsics scaled.
    r = run(cli, "cameras", "--dataset", ds, "--images", "images", "-o", tmp_path / "c.json")
    assert r.returncode == 0, r.stderr
    assert json.loads((tmp_path / "c.json").read_text())["w"] == 8


def test_colmap_binary_models_refuse_trailing_junk(cli, tmp_path):
    src = os.path.join(os.path.dirname(__file__), "..", "data", "colmap_beer")
    ds = tmp_path / "beer"
    shutil.copytree(src, ds)
    with open(ds / "sparse" / "0" / "images.bin", "ab") as f:
        f.write(b"\x01\x02\x03")
    r = run(cli, "cameras", "--dataset", ds, "-o", tmp_path / "c.json")
    assert r.returncode == 1 and "images.bin" in r.stderr and "3 bytes of trailing junk" in r.stderr, r.stderr


def nerfstudio_dataset(ptir, folder, frames_extra=(), tail=""):
    (folder / "images").mkdir(parents=True)
    frames = []
    for i, name in enumerate(("a.png", "b.png")):
        ptir.write_image(str(folder / "images" / name), np.full((6, 8, 3), 0.5, np.float32))
        frames.append({"file_path": "images/" + name, "transform_matrix": np.eye(4).tolist()})
    frames += list(frames_extra)
    (folder / "transforms.json").write_text(json.dumps(
        {"fl_x": 10, "fl_y": 10, "cx": 4, "cy": 3, "w": 8, "h": 6, "frames": frames}) + tail)
    return folder


def test_nerfstudio_refuses_duplicates_and_trailing_junk(cli, ptir, tmp_path):
    dup = nerfstudio_dataset(ptir, tmp_path / "dup",
                             frames_extra=[{"file_path": "images/a.png", "transform_matrix": np.eye(4).tolist()}])
    r = run(cli, "cameras", "--dataset", dup, "-o", tmp_path / "c.json")
    assert r.returncode == 1 and "frames[2].file_path" in r.stderr and "twice" in r.stderr, r.stderr
    junk = nerfstudio_dataset(ptir, tmp_path / "junk", tail="\n}{ trailing")
    r = run(cli, "cameras", "--dataset", junk, "-o", tmp_path / "c.json")
    assert r.returncode == 1 and str(junk / "transforms.json") in r.stderr and "JSON" in r.stderr, r.stderr


def test_a_corrupt_photo_is_found_before_the_first_iteration(cli, dataset, tmp_path):  # noqa: F811
    ds = tmp_path / "ds"
    shutil.copytree(dataset, ds)
    photo = ds / "train_004" / "rgba.png"
    photo.write_bytes(photo.read_bytes()[: photo.stat().st_size // 2])
    out = tmp_path / "out"
    r = run(cli, "optimize", "--dataset", ds, "--gaussians", ds / "g.ply", "--out", out, "--iters", 3,
            "--checkpoint-every", 1, "--spp", 1, "--threads", 1, "--env-size", "16x8", "--fit-iters", 0, "-q",
            timeout=300)
    assert r.returncode == 1 and str(photo) in r.stderr, r.stderr[-2000:]
    assert not (out / "checkpoint.bin").exists()  # was found when view 4 was first drawn, after a checkpoint
