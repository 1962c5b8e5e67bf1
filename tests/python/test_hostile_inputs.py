"""Nothing lost on the surfaces added since the last hostile pass (issue 54): each kind of bad input,
fed to the real CLI, is refused at its cause with a message that names the file and the problem.

- an image header declaring more pixels than memory holds (a texture, an environment) is refused
  against the memory budget before anything is allocated, naming the file (was std::bad_alloc);
- per-splat materials outside [0, 1] in a PLY are refused on every command, naming the file, the
  property and the Gaussian (were rendered as NaN pixels, exit 0);
- a NUL inside a file name of a scene file is an error (the name was cut at it);
- a cameras.json entry's size, focal length and principal point are checked where they are read,
  naming the file and the key; a PLY-only orbit that cannot be placed says why (a floater, huge scales).
"""

import json
import resource
import struct
import subprocess
import zlib
from pathlib import Path

import numpy as np
import pytest

from ptir_testing import look_down_minus_z, write_splat_ply

GIB = 1 << 30


def run(cli, *args, limit_bytes=None, timeout=300):
    """The CLI, optionally under an address-space limit (ulimit -v), as a user with 4 GB would run it."""
    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (limit_bytes, limit_bytes))
    return subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True, timeout=timeout,
                          preexec_fn=limit if limit_bytes else None)


def png_header(width, height, colour_type):
    """A PNG whose header declares width x height (8-bit; 0 grey, 2 RGB) and whose data is a few bytes."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, colour_type, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + chunk(b"IEND", b""))


def splat_ply_with_materials(path, n=16, bad=None):
    """A 4x4 wall of splats with albedo, roughness and metallic columns; bad = (property, gaussian, value)."""
    g = np.linspace(-0.5, 0.5, 4)
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)[:n]
    names = ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
             "rot_0", "rot_1", "rot_2", "rot_3", "albedo_0", "albedo_1", "albedo_2", "roughness", "metallic"]
    rec = np.zeros(n, dtype=[(k, "<f4") for k in names])
    rec["x"], rec["y"], rec["z"] = xy[:, 0], xy[:, 1], -4.0
    rec["opacity"] = 3.0
    for k in range(3):
        rec["scale_%d" % k] = np.log(0.2 if k < 2 else 1e-3)
        rec["albedo_%d" % k] = 0.5
    rec["rot_0"] = 1.0
    rec["roughness"] = 0.5
    if bad:
        rec[bad[0]][bad[1]] = bad[2]
    header = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
    header += "".join("property float %s\n" % k for k in names) + "end_header\n"
    path.write_bytes(header.encode() + rec.tobytes())
    return path


@pytest.fixture()
def scene_dir(tmp_path, wall_scene):
    """A scene file builder in wall_scene's folder: the wall's splats, the back quad, one camera."""
    def write(name="scene.json", gaussians=None, mesh_file=None, material=None, environment=None):
        doc = {"gaussians": [{"file": str(gaussians or wall_scene["ply"])}],
               "meshes": [{"name": "back", "file": mesh_file or str(wall_scene["mesh"]),
                           "material": material or {"base_color": [0.5, 0.5, 0.5]}}],
               "lights": [{"type": "point", "position": [0.0, 0.0, 0.0], "power": 100.0}],
               "cameras": [{"name": "cam", "transform": look_down_minus_z().tolist(), "fov_x": 0.9,
                            "width": 16, "height": 12}],
               "integrator": {"spp": 1, "bounces": 1}}
        if environment:
            doc["environment"] = {"type": "latlong", "file": environment}
        path = tmp_path / name
        path.write_text(json.dumps(doc))
        return path
    return write


# --- image headers past the memory budget --------------------------------------------------------

@pytest.mark.parametrize("use", ["texture", "environment"])
@pytest.mark.parametrize("size,colour", [(30000, 0), (26000, 2)], ids=["30000sq_grey", "26000sq_rgb"])
def test_an_image_header_past_the_memory_budget_is_refused_naming_the_file(cli, scene_dir, tmp_path, use, size,
                                                                          colour):
    bad = tmp_path / "huge.png"
    bad.write_bytes(png_header(size, size, colour))
    assert bad.stat().st_size < 200
    scene = (scene_dir(material={"base_color": {"texture": str(bad)}}) if use == "texture"
             else scene_dir(environment=str(bad)))
    r = run(cli, "render", scene, "-o", tmp_path / "out.exr", "-q", limit_bytes=4 * GIB)
    assert r.returncode == 1, (r.returncode, r.stderr)
    assert str(bad) in r.stderr and "%dx%d" % (size, size) in r.stderr and "memory budget" in r.stderr, r.stderr
    assert "ulimit -v" in r.stderr and "bad_alloc" not in r.stderr, r.stderr
    assert not (tmp_path / "out.exr").exists()


def test_an_exr_data_window_past_the_side_limit_is_refused_before_openexr_allocates(cli, scene_dir, tmp_path):
    """fuzz_texture's finding: a 165-byte EXR declaring a 14-million-pixel-wide data window, for which
    OpenEXR allocated its line buffers on opening (10 s to free them under ASan)."""
    seed = Path(__file__).resolve().parents[1] / "fuzz" / "corpus" / "texture" / "timeout_exr_data_window_14m"
    bad = tmp_path / "wide.exr"
    bad.write_bytes(seed.read_bytes()[1:])  # (the first byte is the harness's extension choice)
    r = run(cli, "render", scene_dir(material={"base_color": {"texture": str(bad)}}), "-o", tmp_path / "o.exr", "-q")
    assert r.returncode == 1 and str(bad) in r.stderr and "dataWindow declares 14286849x1" in r.stderr, r.stderr


# --- per-splat materials outside [0, 1] ----------------------------------------------------------

BAD_MATERIALS = [("albedo_0", 5, 1e30), ("albedo_1", 5, -5.0), ("roughness", 5, 7.0), ("metallic", 5, -3.0),
                 ("albedo_2", 9, 1.0001)]


@pytest.mark.parametrize("prop,index,value", BAD_MATERIALS, ids=[b[0] + "_" + str(b[2]) for b in BAD_MATERIALS])
def test_ply_materials_outside_their_range_are_refused_on_every_command(cli, scene_dir, wall_scene, tmp_path, prop,
                                                                       index, value):
    ply = splat_ply_with_materials(tmp_path / "bad.ply", bad=(prop, index, value))

    def refused(r):
        text = r.stderr if isinstance(r, subprocess.CompletedProcess) else r["error"]
        return (str(ply) in text and "'%s'" % prop in text and "Gaussian %d," % index in text
                and "[0, 1]" in text), text

    r = run(cli, "render", "--gaussians", ply, "--cameras", wall_scene["cameras"], "-o", tmp_path / "a.exr", "-q")
    assert r.returncode == 1 and refused(r)[0], (r.returncode, r.stderr)
    r = run(cli, "render", scene_dir(gaussians=ply), "-o", tmp_path / "b.exr", "-q")
    assert r.returncode == 1 and refused(r)[0], (r.returncode, r.stderr)
    r = run(cli, "optimize", "--gaussians", ply, "--out", tmp_path / "opt", "--iters", 1, "-q")
    assert r.returncode == 1 and refused(r)[0], (r.returncode, r.stderr)
    assert not any((tmp_path / n).exists() for n in ("a.exr", "b.exr", "opt/gaussians.ply"))
    # serve: the same rule, on load and on splat_materials (one function: material_range.h)
    from test_serve_hardening import Raw
    e = Raw(cli, out=tmp_path)
    reply = e.call({"cmd": "load", "scene": str(scene_dir(gaussians=ply)), "id": 1})
    assert not reply["ok"] and refused(reply)[0], reply
    assert e.call({"cmd": "load", "scene": str(scene_dir(name="good.json")), "id": 2})["ok"]
    values = np.full(81 * 5, 0.5, np.float32)
    offset = {"albedo_0": 0, "albedo_1": 1, "albedo_2": 2}.get(prop, 81 * 3 + (81 if prop == "metallic" else 0))
    values[(3 * index if prop.startswith("albedo") else index) + offset] = value
    values.tofile(tmp_path / "mat.f32")
    reply = e.call({"cmd": "splat_materials", "file": str(tmp_path / "mat.f32"), "id": 3})
    assert not reply["ok"] and "'%s'" % prop in reply["error"] and "Gaussian %d," % index in reply["error"], reply
    assert e.close() == 0


def test_ply_materials_at_their_limits_render(cli, wall_scene, tmp_path, ptir):
    ply = splat_ply_with_materials(tmp_path / "edge.ply", bad=("roughness", 3, 1.0))
    r = run(cli, "render", "--gaussians", ply, "--cameras", wall_scene["cameras"], "-o", tmp_path / "a.exr", "-q")
    assert r.returncode == 0, r.stderr
    assert np.isfinite(ptir.read_image(str(tmp_path / "a.exr"))).all()


# --- NUL inside file names -----------------------------------------------------------------------

def test_a_nul_inside_a_file_name_is_an_error(cli, scene_dir, wall_scene, tmp_path, ptir):
    good = tmp_path / "good.png"
    ptir.write_image(str(good), np.full((4, 4, 3), 0.5, np.float32))
    for scene in (scene_dir(material={"base_color": {"texture": str(good) + "\0x"}}),
                  scene_dir(mesh_file=str(wall_scene["mesh"]) + "\0x")):
        r = run(cli, "render", scene, "-o", tmp_path / "out.exr", "-q")
        assert r.returncode == 1 and "NUL" in r.stderr and str(scene) in r.stderr, (r.returncode, r.stderr)
        assert ("texture" in r.stderr) != ("meshes[0].file" in r.stderr), r.stderr
    assert not (tmp_path / "out.exr").exists()


# --- cameras.json and PLY-only orbits ------------------------------------------------------------

def cameras_json(path, **changes):
    cam = {"id": 0, "img_name": "a", "width": 64, "height": 48, "position": [0.0, 0.0, 0.0],
           "rotation": [[1, 0, 0], [0, -1, 0], [0, 0, -1]], "fx": 60.0, "fy": 60.0}
    path.write_text(json.dumps([dict(cam, **changes), dict(cam, id=1, img_name="b")]))
    return path


@pytest.mark.parametrize("key,value", [("width", 1e9), ("height", 0.5), ("cx", "nan"), ("cx", 1e30), ("cy", -1e6),
                                       ("fx", 1e300)])
def test_cameras_json_values_are_checked_where_they_are_read(cli, wall_scene, tmp_path, key, value):
    cams = cameras_json(tmp_path / "cameras.json", **{key: value})
    r = run(cli, "optimize", "--gaussians", wall_scene["ply"], "--cameras", cams, "--out", tmp_path / "out",
            "--iters", 1, "--spp", 1, "-q")
    assert r.returncode == 1, (r.returncode, r.stderr)
    assert str(cams) in r.stderr and "camera [0] '%s'" % key in r.stderr, r.stderr


def test_cameras_json_with_an_off_centre_principal_point_is_read(cli, wall_scene, tmp_path):
    cams = cameras_json(tmp_path / "cameras.json", cx=40.0, cy=20.0)
    r = run(cli, "render", "--gaussians", wall_scene["ply"], "--cameras", wall_scene["cameras"], "-o",
            tmp_path / "x.exr", "-q")
    assert r.returncode == 0, r.stderr
    r = run(cli, "optimize", "--gaussians", wall_scene["ply"], "--cameras", cams, "--out", tmp_path / "out",
            "--estimate", "-q")
    assert r.returncode == 0, r.stderr


def orbit_ply(path, floater=None, log_scale=None):
    pos = np.column_stack([np.random.default_rng(0).uniform(-0.5, 0.5, (48, 2)), np.full(48, -4.0)])
    if floater is not None:
        pos[17] = floater
    ply = write_splat_ply(path, pos, (0.05, 0.05, 0.05), sh_rest=0)
    if log_scale is not None:  # every scale_k set to log_scale
        data = bytearray(ply.read_bytes())
        head = data.index(b"end_header\n") + len(b"end_header\n")
        names = [ln.split()[-1] for ln in data[:head].decode().splitlines() if ln.startswith("property")]
        rec = np.frombuffer(bytes(data[head:]), dtype=[(k, "<f4") for k in names]).copy()
        for k in range(3):
            rec["scale_%d" % k] = log_scale
        ply.write_bytes(bytes(data[:head]) + rec.tobytes())
    return ply


@pytest.mark.parametrize("case", ["floater", "log_scale_80"])
def test_a_ply_only_orbit_that_cannot_be_placed_says_why(cli, tmp_path, case):
    ply = orbit_ply(tmp_path / "g.ply", **({"floater": (1e30, 0.0, -4.0)} if case == "floater" else
                                           {"log_scale": 80.0}))
    r = run(cli, "optimize", "--gaussians", ply, "--out", tmp_path / "out", "--iters", 1, "--spp", 1, "-q")
    assert r.returncode == 1, (r.returncode, r.stderr)
    assert str(ply) in r.stderr and "too large to place cameras around" in r.stderr, r.stderr
    if case == "floater":
        assert "positions span" in r.stderr and "1e+30" in r.stderr and "floater" in r.stderr, r.stderr
    else:
        assert "median largest scale" in r.stderr and "log-scale 80" in r.stderr, r.stderr
    assert "degenerate" not in r.stderr and "no extent" not in r.stderr
