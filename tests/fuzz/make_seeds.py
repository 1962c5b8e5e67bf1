"""Writes the seed corpora under tests/fuzz/corpus/ (committed; rerun to regenerate):
small valid inputs of each target's format, the starting points libFuzzer mutates."""
import json
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
C = os.path.join(HERE, "corpus") + "/"
DATA = os.path.join(HERE, "..", "data") + "/"
for t in ("serve", "scene_json", "ply", "colmap", "nerfstudio", "image", "texture", "cameras_json", "orbit", "budget"):
    os.makedirs(C + t, exist_ok=True)

lines = [
    '{"cmd":"status","id":1}',
    '{"cmd":"render","camera_name":"cam","output":"a.raw","id":2,"spp":1}',
    '{"cmd":"render","view":{"c2w":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1],"fx":10,"fy":10,"cx":4,"cy":4,"width":8,'
    '"height":8},"output":"v.raw","spp":2,"first_sample":1,"id":3}',
    '{"cmd":"update","scene":{"lights":[{"type":"point","position":[0,0,0],"power":50}],"integrator":{"spp":1,'
    '"bounces":2}},"id":4}',
    '{"cmd":"splat_materials","offset":0,"count":9,"file":"mat.f32","id":5}',
    '{"cmd":"transform_splats","offset":0,"count":9,"matrix":[1,0,0,0.1,0,1,0,0,0,0,1,0,0,0,0,1],"id":6}',
    '{"cmd":"render","camera_name":"cam","output":"b.exr","aovs":{"depth":"d.exr","albedo":"al.raw"},"id":7}',
    '{"cmd":"cancel","target":2,"id":8}',
    '{"cmd":"update","scene":{"environment":{"color":[0.1,0.2,0.3]}},"id":9}',
    '{"cmd":"render","camera":{"name":"c2","transform":[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],"fov_x":0.8,'
    '"width":8,"height":8},"output":"c.raw","id":10}',
    '{"cmd":"load","scene":"scene.json","id":11}',
    '{"cmd":"mesh_material","mesh":"x","material":{"base_color":[0.5,0.5,0.5]},"id":12}',
]
for i, line in enumerate(lines):
    open(C + "serve/seed%02d" % i, "w").write(line + "\n")
open(C + "serve/seed_all", "w").write("\n".join(lines) + "\n")

eye = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
scenes = [
    {"gaussians": [{"file": "in.ply"}], "lights": [{"type": "point", "position": [0, 0, 0], "power": 100}],
     "cameras": [{"name": "cam", "transform": eye, "fov_x": 0.9, "width": 16, "height": 16}],
     "integrator": {"spp": 1, "bounces": 1, "fixed_offset": 0.001, "self_intersection": "fixed"}},
    {"lights": [{"type": "sun", "direction": [0, 0, -1], "strength": 3},
                {"type": "area", "shape": "disk", "size": 1, "position": [0, 1, 0], "power": 10}],
     "environment": {"color": [0.2, 0.2, 0.2], "strength": 1}, "brdf": "principled"},
    {"meshes": [], "integrator": {"pixel_filter": "box", "filter_width": 1, "light_selection": "all",
                                  "russian_roulette": False}},
    {"version": 1, "comment": "x",
     "cameras": [{"name": "a", "transform": sum(eye, []), "fov_x": 1.0, "width": 4, "height": 4}]},
]
for i, s in enumerate(scenes):
    open(C + "scene_json/seed%d.json" % i, "w").write(json.dumps(s))

props = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
         "rot_0", "rot_1", "rot_2", "rot_3"]


def plain_ply(n, ascii=False, names=props):
    hdr = ("ply\nformat %s 1.0\nelement vertex %d\n" % ("ascii" if ascii else "binary_little_endian", n)
           + "".join("property float %s\n" % p for p in names) + "end_header\n")
    v = np.random.default_rng(1).normal(size=(n, len(names))).astype(np.float32)
    r = names.index("rot_0")
    v[:, r] = 1
    v[:, r + 1:r + 4] = 0
    if ascii:
        return (hdr + "".join(" ".join("%g" % x for x in row) + "\n" for row in v)).encode()
    return hdr.encode() + v.tobytes()


open(C + "ply/plain_bin.ply", "wb").write(plain_ply(4))
open(C + "ply/plain_ascii.ply", "wb").write(plain_ply(3, True))
# 2DGS surfels (no scale_2) and SH degree 4 (72 f_rest)
open(C + "ply/surfels_bin.ply", "wb").write(plain_ply(4, names=[p for p in props if p != "scale_2"]))
open(C + "ply/sh4_bin.ply", "wb").write(plain_ply(2, names=props[:9] + ["f_rest_%d" % i for i in range(72)] + props[9:]))
chunk_props = ["min_x", "min_y", "min_z", "max_x", "max_y", "max_z", "min_scale_x", "min_scale_y", "min_scale_z",
               "max_scale_x", "max_scale_y", "max_scale_z"]
hdr = ("ply\nformat binary_little_endian 1.0\nelement chunk 1\n" + "".join("property float %s\n" % p for p in chunk_props)
       + "element vertex 4\nproperty uint packed_position\nproperty uint packed_rotation\nproperty uint packed_scale\n"
       "property uint packed_color\nend_header\n")
chunk = np.array([-1, -1, -1, 1, 1, 1, -5, -5, -5, -1, -1, -1], np.float32).tobytes()
verts = np.random.default_rng(2).integers(0, 2**32, (4, 4), dtype=np.uint64).astype(np.uint32).tobytes()
open(C + "ply/compressed.ply", "wb").write(hdr.encode() + chunk + verts)

b = DATA + "colmap_beer/sparse/0/"
parts = [open(b + f, "rb").read() for f in ("cameras.bin", "images.bin", "points3D.bin")]
open(C + "colmap/beer_bin", "wb").write(b"\x01" + b"@@@@".join(parts))
txt = ("# Camera list\n1 PINHOLE 8 6 10 10 4 3\n2 SIMPLE_RADIAL 8 6 10 4 3 0.01\n@@@@"
       "# Image list\n1 1 0 0 0 0 0 0 1 a.png\n10 20 1\n2 0.7071 0 0.7071 0 1 0 0 2 b.png\n\n@@@@"
       "1 0 0 1 255 0 0 0.5 1 0 2 0\n")
open(C + "colmap/model_txt", "wb").write(b"\x00" + txt.encode())

frames = [{"file_path": "images/a.png", "transform_matrix": eye},
          {"file_path": "images/b.png", "transform_matrix": [[1, 0, 0, 0.5], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}]
open(C + "nerfstudio/seed0.json", "w").write(json.dumps(
    {"fl_x": 10, "fl_y": 10, "cx": 4, "cy": 3, "w": 8, "h": 6, "camera_model": "OPENCV", "k1": 0.01, "frames": frames}))
open(C + "nerfstudio/seed1.json", "w").write(json.dumps(
    {"camera_angle_x": 0.9, "w": 8, "h": 6, "frames": frames, "camera_model": "OPENCV_FISHEYE", "k1": 0.1}))
fox = json.load(open(DATA + "fox/transforms.json"))
fox["frames"] = [dict(f, file_path=p["file_path"]) for f, p in zip(fox["frames"][:2], frames)]
open(C + "nerfstudio/fox2.json", "w").write(json.dumps(fox))

# Images: a small PNG written here (zlib), EXRs by the engine's writer when its module is importable
# (PTIR_BUILD_DIR/python), as the first byte's extension choice expects (odd: .exr, even: .png).
import struct
import sys
import zlib


def png(w, h, rgb):
    raw = b"".join(b"\x00" + bytes(rgb[y * w * 3:(y + 1) * w * 3]) for y in range(h))
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


open(C + "image/rgb.png", "wb").write(b"\x00" + png(4, 3, [(i * 37) % 256 for i in range(36)]))
build = os.environ.get("PTIR_BUILD_DIR")
if build:
    sys.path.insert(0, os.path.join(build, "python"))
    import ptir
    import tempfile
    with tempfile.TemporaryDirectory() as d:
        for name, shape in (("rgba.exr", (3, 4, 4)), ("rgb.exr", (2, 2, 3))):
            ptir.write_image(os.path.join(d, name), np.random.default_rng(3).random(shape, np.float32))
            open(C + "image/" + name, "wb").write(b"\x01" + open(os.path.join(d, name), "rb").read())


# Textures (first byte as for images; bit 1: sRGB): headers declaring 30000^2 grey (138 bytes: the
# reproducer of issue 54) and 26000^2 RGB, refused against the memory budget; a small real one.
def png_header_only(w, h, colour_type):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + chunk(b"IEND", b""))


def exr_header_only(w, h):
    """A scanline EXR of 3 half channels whose data window declares w x h, with no pixels."""
    def attr(name, kind, data):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(data)) + data
    chl = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 1, 0, 1, 1) for c in "BGR") + b"\0"
    box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    hdr = (attr("channels", "chlist", chl) + attr("compression", "compression", b"\0")
           + attr("dataWindow", "box2i", box) + attr("displayWindow", "box2i", box)
           + attr("lineOrder", "lineOrder", b"\0") + attr("pixelAspectRatio", "float", struct.pack("<f", 1))
           + attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0))
           + attr("screenWindowWidth", "float", struct.pack("<f", 1)) + b"\0")
    return b"\x76\x2f\x31\x01" + struct.pack("<i", 2) + hdr + struct.pack("<Q", 0) * 4


open(C + "texture/huge_grey.png", "wb").write(b"\x00" + png_header_only(30000, 30000, 0))
open(C + "texture/huge_rgb_srgb.png", "wb").write(b"\x02" + png_header_only(26000, 26000, 2))
open(C + "texture/huge.exr", "wb").write(b"\x01" + exr_header_only(30000, 30000))
open(C + "texture/rgb.png", "wb").write(b"\x02" + png(4, 3, [(i * 53) % 256 for i in range(36)]))

# cameras.json (3DGS): two cameras, one with an off-centre principal point.
rot = [[1, 0, 0], [0, -1, 0], [0, 0, -1]]
open(C + "cameras_json/two.json", "w").write(json.dumps([
    {"id": 0, "img_name": "a", "width": 64, "height": 48, "position": [0, 0, 3], "rotation": rot, "fx": 60, "fy": 60},
    {"id": 1, "img_name": "b", "width": 64, "height": 48, "position": [3, 0, 0], "rotation": rot, "fx": 60.5,
     "fy": 60.5, "cx": 30.5, "cy": 25}]))

# PLY-only plans (first byte: the orbit's options): 48 splats with materials, and one floater at 1e30.
mat_props = props + ["albedo_0", "albedo_1", "albedo_2", "roughness", "metallic"]
body = plain_ply(48, names=mat_props)
vals = np.frombuffer(body[body.index(b"end_header\n") + 11:], np.float32).reshape(48, len(mat_props)).copy()
vals[:, len(props):] = 0.5
hdr48 = body[:body.index(b"end_header\n") + 11]
open(C + "orbit/materials.ply", "wb").write(b"\x00" + hdr48 + vals.tobytes())
vals[7, 0] = 1e30
open(C + "orbit/floater.ply", "wb").write(b"\x21" + hdr48 + vals.tobytes())

# Budget strings.
for i, text in enumerate(["90", "90s", "10m", "1.5h", "2min", "1e9h", "2147483648s", "1e-300s", " 5m"]):
    open(C + "budget/seed%d" % i, "w").write(text)
