"""Runs inside Blender: the native module imports into Blender's Python and renders.

    blender -b --factory-startup -noaudio --python-exit-code 1 \
        -P tests/blender/blender_render_check.py -- <dir with ptir*.so> <tmpdir>

Writes a one-Gaussian 3DGS PLY, renders the opacity and normal AOVs through
`ptir` and checks the numbers. Exits 1 on any failure: `blender -b` would exit 0
after an uncaught exception, so every failure path calls sys.exit explicitly.
"""

import math
import os
import sys
import traceback

import numpy as np

SIZE = 33  # odd: the centre pixel's ray is the optical axis


def write_one_gaussian_ply(path):
    """One flat Gaussian (sigma 1, 1, 0.01) at (0, 0, -5), opacity 0.999, INRIA layout."""
    names = (["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"]
             + ["f_rest_%d" % i for i in range(45)]
             + ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"])
    rec = np.zeros(1, dtype=[(n, "<f4") for n in names])
    rec["z"] = -5.0
    rec["scale_0"], rec["scale_1"], rec["scale_2"] = 0.0, 0.0, math.log(0.01)
    rec["rot_0"] = 1.0
    rec["opacity"] = math.log(0.999 / 0.001)
    header = "ply\nformat binary_little_endian 1.0\nelement vertex 1\n"
    header += "".join("property float %s\n" % n for n in names) + "end_header\n"
    with open(path, "wb") as f:
        f.write(header.encode("ascii") + rec.tobytes())


def check(cond, what):
    if not cond:
        raise AssertionError(what)


def main(module_dir, tmpdir):
    sys.path.insert(0, module_dir)
    import ptir
    check(os.path.dirname(os.path.abspath(ptir.__file__)) == os.path.abspath(module_dir),
          "imported ptir from %s, not %s" % (ptir.__file__, module_dir))
    ply = os.path.join(tmpdir, "one.ply")
    write_one_gaussian_ply(ply)
    field = ptir.load_gaussians(ply)
    check(len(field) == 1, "expected 1 Gaussian, got %d" % len(field))
    scene = ptir.Scene(field, [], 16)
    cam = ptir.Camera(np.eye(4, dtype=np.float32), math.radians(60.0), SIZE, SIZE)

    opacity = scene.render_aov(cam, "opacity")
    check(opacity.shape == (SIZE, SIZE, 1), "opacity shape %s" % (opacity.shape,))
    centre = float(opacity[SIZE // 2, SIZE // 2, 0])
    check(centre > 0.9, "coverage at the centre %.4f <= 0.9" % centre)
    # 3 sigma at distance 5 is ~31 degrees off axis; the corners are ~39 degrees off.
    corners = opacity[[0, 0, -1, -1], [0, -1, 0, -1], 0]
    check(np.all(corners == 0.0), "coverage in the corners %s" % corners)

    normal = scene.render_aov(cam, "normal")
    n = normal[SIZE // 2, SIZE // 2, :3]
    check(np.allclose(n, [0.0, 0.0, 1.0], atol=1e-3), "normal at the centre %s, expected +z" % n)
    depth = float(scene.render_aov(cam, "depth")[SIZE // 2, SIZE // 2, 0])
    check(abs(depth - 5.0) < 1e-3, "depth at the centre %.4f, expected 5" % depth)
    print("blender_render_check: OK (Python %d.%d, coverage %.4f at the centre, 0 in the corners, depth %.3f)"
          % (sys.version_info[0], sys.version_info[1], centre, depth))


if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    try:
        if len(argv) != 2:
            raise SystemExit("usage: blender -b -P blender_render_check.py -- <module dir> <tmpdir>")
        main(*argv)
    except BaseException as e:  # includes SystemExit from the usage line
        traceback.print_exc()
        print("blender_render_check: FAILED: %s" % e, file=sys.stderr)
        sys.stdout.flush()
        sys.exit(1)
    sys.stdout.flush()
    sys.exit(0)
