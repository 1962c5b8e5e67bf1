#!/usr/bin/env python3
"""Before/after picture of a bare splat PLY made relightable (docs/relightable.md).

    python3 scripts/relight_any_splat.py SPLATS.ply --out DIR [--env A.exr --env B.exr]
                                         [--optimize "FLAGS"] [--build build]

1. `ptir optimize --gaussians SPLATS.ply --out DIR/result` (no photos: the splats' own radiance is
   the target; any extra flags with --optimize, e.g. "--iters 200" for a quick look). A finished
   result in DIR/result is reused; --resume continues a stopped one.
2. One camera at a three-quarter view of the splats' robust bounds (DIR/result/views.json), at the
   orbit's distance, 30 degrees up: up is the splats' up axis the command decided and recorded there
   (views.json "up_axis": from --up, a cameras.json, the SH or the file's convention; docs/relightable.md),
   so a trainer's PLY in its capture's frame (often -y up) stands on the floor. Give
   --optimize "--up -y" when the decision is wrong.
3. Panels, left to right: the splats as they were captured (their SH radiance composited, what
   Blender shows: `ptir render --aov preview`); then the recovered asset with a grey floor and a
   grey sphere beside it, under each new environment (`ptir relight`, 128 spp, 3 bounces).
4. DIR/relight_any_splat.png (sRGB; each relit panel exposed on its own, the captured one shown as
   stored) and each panel as EXR/PNG beside it.

Default environments: the dataset maker's `sunset` and `overcast` presets (scripts/dataset/envmaps.py),
written into DIR/env_*.exr. Needs the built CLI and Python module (`make build`).
"""

import argparse
import json
import math
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))


def run(cmd):
    print("relight_any_splat: " + " ".join(shlex.quote(str(c)) for c in cmd), flush=True)
    subprocess.run([str(c) for c in cmd], check=True)


def horizontal_axes(up):
    """(e1, e2): with up a right-handed orthonormal frame; +x and +y for +z up (scene/orbit_views.h's)."""
    ref = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = ref - np.dot(ref, up) * up
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(up, e1)


def build_tools(args, tool):
    """(the CLI's path, the build's Python module) after checking --env was given twice or not at all."""
    if args.env is not None and len(args.env) != 2:
        sys.exit("%s: error: give --env twice (two new environments), or not at all" % tool)
    sys.path.insert(0, str(args.build / "python"))
    import ptir  # noqa: E402  (the build's module)
    return args.build / "bin" / "ptir", ptir


def new_environments(ptir, out, envs):
    """The two environments to relight under: the given ones, else the dataset maker's `sunset` and
    `overcast` presets written into OUT/env_*.exr."""
    if envs is not None:
        return envs
    from dataset import envmaps  # the dataset maker's presets (numpy only)
    envs = []
    for name in ("sunset", "overcast"):
        path = out / ("env_%s.exr" % name)
        ptir.write_image(str(path), np.ascontiguousarray(envmaps.make_envmap(name, 256, 128), np.float32))
        envs.append(path)
    return envs


def three_quarter_camera(bounds, up, fov_x, width, height):
    """A NeRF transforms document with one camera looking at the bounds' centre, 30 degrees above it
    about `up` (a unit vector), its image upright."""
    centre, radius = np.asarray(bounds["centre"], float), float(bounds["radius"])
    dist = radius / math.sin(fov_x / 2.0) * 1.6  # room for the sphere beside it
    az, el = math.radians(-55.0), math.radians(30.0)
    e1, e2 = horizontal_axes(up)
    eye = centre + dist * (math.cos(el) * (math.cos(az) * e1 + math.sin(az) * e2) + math.sin(el) * up)
    back = (eye - centre) / np.linalg.norm(eye - centre)
    right = np.cross(up, back)
    right /= np.linalg.norm(right)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, np.cross(back, right), back, eye
    fl = 0.5 * width / math.tan(fov_x / 2.0)
    return {"camera_angle_x": fov_x, "fl_x": fl, "fl_y": fl, "cx": width / 2, "cy": height / 2, "w": width,
            "h": height, "frames": [{"file_path": "view", "transform_matrix": m.tolist()}]}


def floor_height(ptir, ply, up):
    """Where the splats stand along `up`: the 1st opacity-weighted percentile of their heights (opacity
    >= 0.05, as the orbit's bounds: a stray splat under the object does not sink the floor)."""
    field = ptir.load_gaussians(str(ply))
    p, w = np.asarray(field.position, float), np.asarray(field.opacity, float)
    keep = w >= 0.05
    h, w = p[keep] @ up, w[keep]
    order = np.argsort(h)
    cum = np.cumsum(w[order])
    return float(h[order][np.searchsorted(cum, 0.01 * cum[-1])])


def floor_and_sphere(bounds, up, height, path, right):
    """An ASCII PLY: a floor across `up` at `height` under the bounds and a sphere of 0.35 their radius
    on it, to the camera's right."""
    centre, radius = np.asarray(bounds["centre"], float), float(bounds["radius"])
    s = 4.0 * radius
    e1, e2 = horizontal_axes(up)
    c0 = centre + (height - np.dot(centre, up)) * up  # the centre dropped onto the floor
    verts = [tuple(c0 + s * (a * e1 + b * e2)) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    normals = [tuple(up)] * 4  # vertex normals: the sphere shades smooth
    faces = [(0, 1, 2), (0, 2, 3)]
    r = 0.35 * radius
    side = np.asarray(right, float) - np.dot(right, up) * up
    c = c0 + 1.25 * radius * side / max(np.linalg.norm(side), 1e-9) + r * up
    nu, nv = 24, 12
    base = len(verts)
    for j in range(nv + 1):
        th = math.pi * j / nv
        for i in range(nu):
            ph = 2.0 * math.pi * i / nu
            n = math.sin(th) * math.cos(ph) * e1 + math.sin(th) * math.sin(ph) * e2 + math.cos(th) * up
            verts.append(tuple(c + r * n))
            normals.append(tuple(n))
    for j in range(nv):
        for i in range(nu):
            a, b = base + j * nu + i, base + j * nu + (i + 1) % nu
            faces += [(a, a + nu, b + nu), (a, b + nu, b)]
    lines = ["ply", "format ascii 1.0", "element vertex %d" % len(verts), "property float x", "property float y",
             "property float z", "property float nx", "property float ny", "property float nz",
             "element face %d" % len(faces), "property list uchar int vertex_indices", "end_header"]
    lines += ["%.6f %.6f %.6f %.6f %.6f %.6f" % (v + n) for v, n in zip(verts, normals)]
    lines += ["3 %d %d %d" % f for f in faces]
    path.write_text("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("ply", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--env", type=Path, action="append", help="lat-long environment (.exr/.hdr); give two")
    ap.add_argument("--optimize", default="", help="extra flags for ptir optimize")
    ap.add_argument("--build", type=Path, default=ROOT / "build")
    ap.add_argument("--size", type=int, default=320, help="panel width and height in pixels")
    ap.add_argument("--spp", type=int, default=128)
    args = ap.parse_args()
    if not args.ply.is_file():
        sys.exit("relight_any_splat: error: %s: no such file" % args.ply)
    cli, ptir = build_tools(args, "relight_any_splat")

    out = args.out
    result = out / "result"
    out.mkdir(parents=True, exist_ok=True)
    if not (result / "gaussians.ply").is_file():
        run([cli, "optimize", "--gaussians", args.ply, "--out", result] + shlex.split(args.optimize))
    envs = new_environments(ptir, out, args.env)

    views = json.loads((result / "views.json").read_text())
    bounds = views["bounds"]
    up = np.asarray(views.get("up_axis", {}).get("up", [0.0, 0.0, 1.0]), float)  # (older results: +z)
    up /= np.linalg.norm(up)
    print("relight_any_splat: up (%.3f, %.3f, %.3f) from %s" % (tuple(up) + (views.get("up_axis", {}).get(
        "source", "an older result: +z"),)), flush=True)
    cams = out / "picture_camera.json"
    camera = three_quarter_camera(bounds, up, math.radians(40.0), args.size, args.size)
    cams.write_text(json.dumps(camera))
    props = out / "floor_and_sphere.ply"
    floor_and_sphere(bounds, up, floor_height(ptir, args.ply, up), props,
                     np.asarray(camera["frames"][0]["transform_matrix"])[:3, 0])

    baked = out / "captured.exr"
    run([cli, "render", "--gaussians", args.ply, "--cameras", cams, "--frame", 0, "--aov", "preview",
         "--spp", 16, "-o", baked, "-q", "--force"])
    panels = [np.asarray(ptir.read_image(str(baked)), np.float32)]
    relit = []
    for k, env in enumerate(envs):
        d = out / ("relit_%d" % k)
        run([cli, "relight", "--result", result, "--cameras", cams, "--frame", 0, "--env", env, "--mesh", props,
             "--mesh-color", "0.6,0.6,0.6", "--mesh-roughness", "0.4", "--spp", args.spp, "--bounces", 3, "-o", d,
             "-q", "--force"])
        exrs = sorted(d.glob("*.exr"))
        if not exrs:
            sys.exit("relight_any_splat: error: ptir relight wrote no EXR into %s" % d)
        relit.append(np.asarray(ptir.read_image(str(exrs[0])), np.float32))
    # Each relit panel exposed on its own (the environments differ in level): 99th percentile luminance at 0.9.
    for r in relit:
        exposure = 0.9 / max(float(np.percentile(r[..., :3].mean(-1), 99.0)), 1e-6)
        panels.append(r * np.array([exposure] * 3 + [1.0] * (r.shape[-1] - 3), np.float32))
    rgb = []
    for p in panels:
        c = p[..., :3]
        if p.shape[-1] > 3:  # composite over mid grey where the splats leave the background
            c = c + (1.0 - p[..., 3:4]) * 0.18
        rgb.append(np.clip(c, 0.0, 1.0))
    gap = np.ones((args.size, 4, 3), np.float32)
    sheet = np.concatenate(sum(([p, gap] for p in rgb), [])[:-1], axis=1)
    ptir.write_image(str(out / "relight_any_splat.png"), np.ascontiguousarray(sheet, np.float32))
    print("relight_any_splat: wrote %s (captured | relit under %s)" % (out / "relight_any_splat.png",
                                                                      " | ".join(e.stem for e in envs)))


if __name__ == "__main__":
    main()
