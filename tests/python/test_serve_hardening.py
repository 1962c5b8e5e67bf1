"""`ptir serve` as a hardened boundary (issue #40; docs/robustness.md, docs/engine_protocol.md): every
line answered (on its id when it has one), the session alive after any bad line, sizes under `ptir
render`'s memory budget, quit and the end of input honoured within a second during a render, cancel
only for ids seen, and no render over the loaded scene's own files. Raw bytes on a pipe, no client
library: the point is what a careless script sends."""

import json
import os
import select
import subprocess
import time

import numpy as np
import pytest

W = H = 16


def scene_file(wall_scene, tmp_path):
    scene = {
        "gaussians": [{"file": str(wall_scene["ply"])}],
        "meshes": [{"name": "back", "file": str(wall_scene["mesh"]), "material": {"base_color": [0.5, 0.5, 0.5]}}],
        "lights": [{"type": "point", "position": [0.0, 0.0, 0.0], "power": 200.0}],
        "cameras": [{"name": "cam", "transform": np.eye(4).tolist(), "fov_x": 0.9, "width": W, "height": H}],
        "integrator": {"spp": 2, "bounces": 1, "seed": 7},
    }
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    return path


class Raw:
    """A serve process fed raw bytes; replies read line by line."""

    def __init__(self, cli, *args, out=None):
        out_args = ["--out", str(out)] if out is not None else []
        self.proc = subprocess.Popen([str(cli), "serve", "-q", *out_args, *args], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        self.buf = b""
        assert self.line(30)["ready"]

    def write(self, data):
        self.proc.stdin.write(data)
        self.proc.stdin.flush()

    def line(self, timeout=60.0):
        end = time.monotonic() + timeout
        while b"\n" not in self.buf:
            left = end - time.monotonic()
            assert left > 0, "no reply within %.0f s" % timeout
            ready, _, _ = select.select([self.proc.stdout], [], [], left)
            if ready:
                chunk = os.read(self.proc.stdout.fileno(), 1 << 16)
                assert chunk, "serve ended (rc %s): %s" % (self.proc.wait(), self.proc.stderr.read()[-2000:])
                self.buf += chunk
        line, self.buf = self.buf.split(b"\n", 1)
        return json.loads(line)

    def reply(self, timeout=60.0):
        """The next reply, skipping progress lines."""
        while True:
            r = self.line(timeout)
            if "ok" in r:
                return r

    def call(self, request, timeout=60.0):
        self.write(json.dumps(request).encode() + b"\n")
        return self.reply(timeout)

    def close(self):
        if self.proc.poll() is None:
            try:
                self.proc.stdin.close()
            except BrokenPipeError:
                pass
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:  # it did not honour the end of its input: never left running
                self.proc.kill()
                self.proc.wait()
                return "killed"
        return self.proc.returncode


@pytest.fixture()
def engine(cli, wall_scene, tmp_path):
    e = Raw(cli, "--max-memory", "0.5", out=tmp_path)
    path = scene_file(wall_scene, tmp_path)
    assert e.call({"cmd": "load", "scene": str(path), "id": 1})["ok"]
    yield e, path
    assert e.close() == 0


def render(e, out, rid=1000, **kw):
    r = e.call(dict({"cmd": "render", "camera_name": "cam", "output": str(out), "id": rid}, **kw))
    assert r["ok"], r
    return np.fromfile(out, np.float32).reshape(H, W, 4)


BAD_LINES = [  # (line, id the reply must carry, words the error must hold)
    (b'{"id": 2, "cmd": 5}', 2, "cmd"),
    (b'{"id": 3, "cmd": ["render"]}', 3, "cmd"),
    (b'{"id": 4, "cmd": "render", "camera_name": "cam", "spp": 1e400, "output": "x.raw"}', 4, "overflow"),
    (b'{"id": 5, "cmd": "render", "view": {"c2w": [1e400, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], '
     b'"fx": 10, "fy": 10, "cx": 8, "cy": 8, "width": 16, "height": 16}, "output": "x.raw"}', 5, "JSON"),
    (b'{"id": 6, "cmd": "update", "scene": {"lights": [{"type": "point", "position": [0, 0, 0], "power": 1e400}]}}',
     6, "JSON"),
    (b'{"id": 7, "cmd": "cancel", "target": "x"}', 7, "target"),
    (b'{"id": 8, "cmd": "fl\xff\xfe"}', 8, "UTF-8"),
    (b'{"id": 9, "cmd": "status", "extra": 1}', 9, "extra"),
    (b'{"id": "ten", "cmd": "status"}', "ten", "id"),
    (b'{"id": 11, "cmd": "render", "camera_name": "cam", "output": "x.raw", "transparent": "yes"}', 11, "transparent"),
    (b'{"id": 12, "cmd": "render", "view": {"c2w": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], "fx": 1e39, '
     b'"fy": 10, "cx": 8, "cy": 8, "width": 16, "height": 16}, "output": "x.raw"}', 12, "fx"),
    (b'{"id": 13, "cmd": "render", "camera_name": "cam", "width": 16384, "height": 16384, "output": "x.raw"}', 13,
     "memory"),
    (b'{"id": 14, "cmd": "render", "view": {"c2w": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], "fx": 10, '
     b'"fy": 10, "cx": 8, "cy": 8, "width": 16384, "height": 16384}, "output": "x.raw"}', 14, "memory"),
    (b'{"id": 15, "cmd": "update", "scene": {"integrator": {"fixed_offset": 1e30}}}', 15, "fixed_offset"),
    (b'{"id": 16, ' + b'[' * 50000 + b']' * 50000 + b'}', 16, "nested"),
    (b'{"id": 17, "cmd": "splat_materials", "file": "/dev/zero"}', 17, "regular file"),
    (b'[1, 2, 3]', None, "object"),
    (b'\xff\xfe\x00garbage', None, "JSON"),
    (b'{"cmd": "status", "id": 18', 18, "JSON"),
]


@pytest.mark.parametrize("line,rid,needle", BAD_LINES, ids=[str(i) for i in range(len(BAD_LINES))])
def test_every_bad_line_is_answered_on_its_id(engine, tmp_path, line, rid, needle):
    e, _ = engine
    e.write(line + b"\n")
    r = e.reply()
    assert r["ok"] is False and not r.get("cancelled"), r
    assert r.get("id") == rid and needle.lower() in r["error"].lower(), r
    assert e.proc.poll() is None
    assert render(e, tmp_path / "after.raw")[..., :3].mean() > 0.01  # still serving, scene intact


def test_infinite_materials_are_refused(engine, tmp_path):
    e, _ = engine
    for bad in (np.inf, np.nan, -1.0):
        f = tmp_path / "mat.f32"
        v = np.full(81 * 5, 0.5, np.float32)
        v[7] = bad
        v.tofile(f)
        r = e.call({"cmd": "splat_materials", "offset": 0, "count": 81, "file": str(f), "id": 3})
        assert not r["ok"] and str(f) in r["error"] and "'albedo_1' is" in r["error"] and "Gaussian 2," in r["error"], r
    assert np.isfinite(render(e, tmp_path / "after.raw")).all()


def test_no_render_over_the_loaded_scenes_files(engine, tmp_path, wall_scene):
    e, path = engine
    before = {p: p.read_bytes() for p in (path, wall_scene["ply"], wall_scene["mesh"])}
    for target in before:
        r = e.call({"cmd": "render", "camera_name": "cam", "output": str(target), "id": 4})
        assert not r["ok"] and "input" in r["error"] and str(target) in r["error"], r
        r = e.call({"cmd": "render", "camera_name": "cam", "output": str(tmp_path / "ok.raw"), "id": 5,
                    "aovs": {"depth": str(target)}})
        assert not r["ok"] and "input" in r["error"], r
    r = e.call({"cmd": "render", "camera_name": "cam", "output": "/dev/null", "id": 6})
    assert not r["ok"] and "regular file" in r["error"], r
    assert all(p.read_bytes() == b for p, b in before.items())
    assert os.path.exists("/dev/null") and not os.path.isfile("/dev/null")


def test_cancel_only_for_ids_seen(engine, tmp_path):
    e, _ = engine
    r = e.call({"cmd": "cancel", "target": 500, "id": 20})
    assert r["ok"] is False and r["id"] == 20 and "500" in r["error"], r
    # 500 arrives later: it is not cancelled by the earlier, unknown-id cancel.
    assert render(e, tmp_path / "later.raw", rid=500)[..., :3].mean() > 0.01
    # A cancel for a finished request is quietly nothing (no reply of its own): the next reply is status's.
    e.write(b'{"cmd": "cancel", "target": 500, "id": 21}\n')
    assert e.call({"cmd": "status", "id": 22})["id"] == 22


def test_a_cancel_of_a_finished_request_does_not_cancel_a_later_one_with_its_id(engine, tmp_path):
    """Issue 54: the cancel of an answered request was remembered, and the next request reusing its id (a
    load) was answered "cancelled"."""
    e, path = engine
    assert render(e, tmp_path / "first.raw", rid=40)[..., :3].mean() > 0.01
    assert e.call({"cmd": "status", "id": 41})["ok"]  # 40 is answered and another request has run since
    e.write(b'{"cmd": "cancel", "target": 40, "id": 42}\n')
    r = e.call({"cmd": "load", "scene": str(path), "id": 40})
    assert r["ok"] and not r.get("cancelled"), r
    assert render(e, tmp_path / "again.raw", rid=40)[..., :3].mean() > 0.01


def test_cancel_and_quit_refuse_fields_they_do_not_read(engine, tmp_path):
    e, _ = engine
    r = e.call({"cmd": "cancel", "target": 1, "targte": 2, "id": 50})
    assert not r["ok"] and r["id"] == 50 and '"targte"' in r["error"] and "target" in r["error"], r
    r = e.call({"cmd": "quit", "now": True, "id": 51})
    assert not r["ok"] and r["id"] == 51 and '"now"' in r["error"] and "takes none" in r["error"], r
    assert e.call({"cmd": "status", "id": 52})["ok"]  # neither was applied: the session still answers
    assert e.proc.poll() is None


def test_renders_go_only_under_the_output_folder(cli, wall_scene, tmp_path):
    """Issue 54: a request's output "../../../../etc/passwd" replaced the system's file. serve --out DIR:
    outputs only under DIR (relative names taken in it), nothing outside it (absolute, "..", a link), and
    no existing file replaced unless this session wrote it."""
    out = tmp_path / "session"
    out.mkdir()
    outside = tmp_path / "outside.raw"
    outside.write_bytes(b"keep me")
    (out / "link").symlink_to(tmp_path)
    mine = out / "theirs.raw"
    mine.write_bytes(b"not the engine's")
    e = Raw(cli, out=out)
    assert e.call({"cmd": "load", "scene": str(scene_file(wall_scene, tmp_path)), "id": 1})["ok"]
    depth = "../" * (len(out.parts) + 2) + str(outside).lstrip("/")
    for name in (depth, "../outside.raw", str(outside), "link/outside.raw", "sub/../../outside.raw"):
        r = e.call({"cmd": "render", "camera_name": "cam", "output": name, "id": 2})
        assert not r["ok"] and "outside this session's output folder" in r["error"] and name in r["error"], r
        r = e.call({"cmd": "render", "camera_name": "cam", "output": "ok.raw", "aovs": {"depth": name}, "id": 3})
        assert not r["ok"] and "outside" in r["error"], r
    r = e.call({"cmd": "render", "camera_name": "cam", "output": str(mine), "id": 4})
    assert not r["ok"] and "not written by this session" in r["error"], r
    assert outside.read_bytes() == b"keep me" and mine.read_bytes() == b"not the engine's"
    assert not (out / "ok.raw").exists()
    # Its own files: written, and written again (a progressive pass reuses its file).
    for _ in range(2):
        r = e.call({"cmd": "render", "camera_name": "cam", "output": "first.raw", "id": 5,
                    "aovs": {"depth": str(out / "first_depth.raw")}})
        assert r["ok"], r
    assert (out / "first.raw").stat().st_size == H * W * 16 and (out / "first_depth.raw").exists()
    assert e.close() == 0
    # A second session does not replace the first one's files.
    e = Raw(cli, out=out)
    assert e.call({"cmd": "load", "scene": str(scene_file(wall_scene, tmp_path)), "id": 1})["ok"]
    r = e.call({"cmd": "render", "camera_name": "cam", "output": "first.raw", "id": 6})
    assert not r["ok"] and "not written by this session" in r["error"], r
    assert e.close() == 0
    p = subprocess.run([str(cli), "serve", "--out", str(outside)], input=b"", capture_output=True, timeout=30)
    assert p.returncode == 1 and str(outside) in p.stderr.decode() and "not a folder" in p.stderr.decode()

@pytest.mark.parametrize("how", ["quit", "eof"])
def test_quit_and_end_of_input_stop_a_long_render_within_a_second(engine, tmp_path, how):
    e, _ = engine
    e.write(json.dumps({"cmd": "render", "camera_name": "cam", "spp": 1 << 20, "width": 256, "height": 256,
                        "output": str(tmp_path / "long.raw"), "id": 30}).encode() + b"\n")
    e.write(json.dumps({"cmd": "status", "id": 31}).encode() + b"\n")
    time.sleep(0.5)  # the render is running
    t0 = time.monotonic()
    if how == "quit":
        e.write(b'{"cmd": "quit"}\n')
    else:
        e.proc.stdin.close()
    r1, r2 = e.reply(5), e.reply(5)
    assert e.proc.wait(5) == 0
    assert time.monotonic() - t0 < 1.0, time.monotonic() - t0
    assert r1["id"] == 30 and r1.get("cancelled") and r2["id"] == 31 and r2.get("cancelled"), (r1, r2)
    assert not (tmp_path / "long.raw").exists()


def test_garbage_bursts_then_exit_cleanly(cli, wall_scene, tmp_path):
    """Bursts of garbage, then the end of input: status 0 every time (was an abort or a segfault while
    exiting in 9 of 20 runs), and one reply per line."""
    rng = np.random.default_rng(5)
    path = scene_file(wall_scene, tmp_path)
    for run in range(8):
        lines = [json.dumps({"cmd": "load", "scene": str(path), "id": 0}).encode()]
        for i in range(150):
            n = int(rng.integers(1, 80))
            junk = bytes(rng.integers(0, 256, n, dtype=np.uint8)).replace(b"\n", b" ")
            lines.append(junk if i % 2 else b'{"id": %d, "cmd": %s}' % (i + 1, junk))
        p = subprocess.run([str(cli), "serve", "-q"], input=b"\n".join(lines) + b"\n", capture_output=True,
                           timeout=60)
        assert p.returncode == 0, (run, p.returncode, p.stderr[-2000:])
        replies = [json.loads(l) for l in p.stdout.splitlines()]
        blank = sum(1 for l in lines if not l.strip(b" \t\r"))
        assert len(replies) == 1 + len(lines) - blank, (len(replies), len(lines))


# --- 10,000 random and mutated lines, then a valid render ---------------------------------------------

STATEFUL = ("load", "update", "mesh_material", "splat_materials", "transform_splats")


def seeds(tmp_path):
    mat = tmp_path / "mat.f32"
    np.full(81 * 5, 0.4, np.float32).tofile(mat)
    view = {"c2w": np.eye(4).reshape(-1).tolist(), "fx": 12.0, "fy": 12.0, "cx": 8.0, "cy": 8.0, "width": 8,
            "height": 8}
    return [
        {"cmd": "status"},
        {"cmd": "render", "view": view, "spp": 2, "output": str(tmp_path / "m.raw")},
        {"cmd": "render", "camera_name": "cam", "spp": 1, "width": 8, "height": 8, "output": str(tmp_path / "n.raw"),
         "aovs": {"depth": str(tmp_path / "d.raw")}},
        {"cmd": "update", "scene": {"lights": [{"type": "point", "position": [0.1, 0, 0], "power": 150.0}]}},
        {"cmd": "update", "scene": {"integrator": {"spp": 2, "bounces": 2, "seed": 3}}},
        {"cmd": "mesh_material", "mesh": "back", "material": {"base_color": [0.2, 0.6, 0.3], "roughness": 0.4}},
        {"cmd": "splat_materials", "offset": 0, "count": 81, "file": str(mat)},
        {"cmd": "transform_splats", "offset": 0, "count": 81,
         "matrix": [1, 0, 0, 0.05, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]},
    ]


def mutate(rng, line):
    b = bytearray(line)
    for _ in range(int(rng.integers(1, 6))):
        op = rng.integers(0, 4)
        at = int(rng.integers(0, len(b) + 1))
        if op == 0 and at < len(b):
            b[at] = int(rng.integers(0, 256))
        elif op == 1:
            b[at:at] = bytes([int(rng.integers(32, 127))])
        elif op == 2 and at < len(b):
            del b[at:at + int(rng.integers(1, 8))]
        elif op == 3:
            b[at:at] = rng.choice([b"1e400", b"-1", b"null", b"[]", b"{}", b'"', b"\\u0000", b"\xff", b"NaN"])
    return bytes(b).replace(b"\n", b" ")


def test_ten_thousand_bad_lines_then_a_bit_identical_render(cli, wall_scene, tmp_path):
    """Random bytes and mutated requests: every line answered, the session alive, and a valid render
    after them bit-identical to a fresh session's that got only the state changes that succeeded."""
    import threading
    path = scene_file(wall_scene, tmp_path)
    rng = np.random.default_rng(40)
    base = [json.dumps(s).encode() for s in seeds(tmp_path)]
    lines = []
    while len(lines) < 10000:
        kind = rng.integers(0, 3)
        if kind == 0:
            line = bytes(rng.integers(0, 256, int(rng.integers(1, 120)), dtype=np.uint8)).replace(b"\n", b" ")
        else:
            line = mutate(rng, base[int(rng.integers(0, len(base)))])
        if line.strip(b" \t\r"):
            lines.append(line)
    e = Raw(cli, out=tmp_path)
    assert e.call({"cmd": "load", "scene": str(path)})["ok"]
    replies = []

    def read_all():
        while len(replies) < len(lines):
            r = e.line(600)
            if "ok" in r:
                replies.append(r)

    reader = threading.Thread(target=read_all)
    reader.start()
    for i in range(0, len(lines), 200):
        e.write(b"\n".join(lines[i:i + 200]) + b"\n")
    reader.join(600)
    assert len(replies) == len(lines) and e.proc.poll() is None
    final = {"cmd": "render", "camera_name": "cam", "spp": 4, "output": str(tmp_path / "after.raw")}
    assert e.call(final)["ok"]
    assert e.close() == 0
    # The state changes that succeeded, replayed in a fresh session.
    applied = []
    for line, r in zip(lines, replies):
        if r["ok"]:
            request = json.loads(line)
            if request["cmd"] in STATEFUL:
                applied.append(request)
    fresh = Raw(cli, out=tmp_path)
    assert fresh.call({"cmd": "load", "scene": str(path)})["ok"]
    for request in applied:
        assert fresh.call(request)["ok"]
    assert fresh.call(dict(final, output=str(tmp_path / "fresh.raw")))["ok"]
    assert fresh.close() == 0
    a, b = (np.fromfile(tmp_path / f, np.float32) for f in ("after.raw", "fresh.raw"))
    assert a.size == H * W * 4 and a[::4].mean() > 0.001
    assert np.array_equal(a, b), np.abs(a - b).max()
    errors = sum(1 for r in replies if not r["ok"])
    assert errors > 9000, errors  # nearly all refused (a mutated line is sometimes still a valid request)
