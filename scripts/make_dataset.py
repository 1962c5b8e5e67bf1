"""The dataset maker: a Blender scene rendered by Cycles into a TensoIR-layout
inverse-rendering dataset with known answers, plus the object's surface as a
3DGS splat file.

Run inside Blender 3.4 (headless), or in PyPI's bpy 4.5 / 5.0 (tests/blender/bpy_run.py runs it the same way):

    blender -b --factory-startup -noaudio --python-exit-code 1 -P scripts/make_dataset.py -- \
        --out DIR [--blend FILE] [--res 100] [--train 16] [--test 8] [--spp 64] [--bounces 4]
        [--subdiv 2] [--train-env studio] [--relight-envs sunset,sky] [--env-size 128x64]
        [--threads N] [--save-blend FILE] [--textured] [--metal-fraction F] [--texture-seed N]
        [--capture-layouts] [--shape NAME] [--texture-kind smooth|edges|hifreq|perface]
        [--roughness-range LO,HI] [--neutral] [--capture-room]

The object: with --blend, the mesh objects of the file's collection "PTIR_Object"
(else every renderable mesh); without, the bundled sample built in code
(scripts/dataset/scene.py: Suzanne on a pedestal, four Principled parts with
metallic 0 and known colour/roughness; sample_blends/sample_object.blend is the
same object saved by sample_blends/build_sample_object.py). With --textured every
material's base colour and roughness (and, with --metal-fraction, metallic patches)
become per-polygon noise patterns (scripts/dataset/textures.py); the oracle stays exact.

Writes (docs/dataset_format.md has the conventions):
    DIR/transforms_train.json, transforms_test.json   NeRF-synthetic cameras, "ptir_brdf": the model Cycles
                                                      rendered with (principled-v1 on 3.x, principled-v2 on 4.0+)
    DIR/train_XXX/rgba.png                            under the training environment
    DIR/test_XXX/rgba.png                             novel view, training environment
    DIR/test_XXX/albedo.png, roughness.png, normal.png ground truth
    DIR/test_XXX/rgba_<env>.png                       relit under each relight environment
    DIR/envmaps/<env>.exr                             every environment (linear lat-long, Blender orientation)
    DIR/gaussians.ply                                 the surface as flat Gaussians (3DGS layout, no normals)
    DIR/oracle/gaussians.ply, oracle/env.exr          a perfect "result" (true materials, face normals,
                                                      training environment) for checking the evaluation
    DIR/dataset.json                                  what was made, with which settings
    DIR/capture/{nerf,colmap_bin,colmap_txt,nerfstudio}/  with --capture-layouts: every training-environment
                                                      view (train and test) as a photographed capture in each
                                                      layout PTIR reads, the COLMAP and nerfstudio ones through
                                                      a distorted OPENCV lens, with masks
                                                      (scripts/dataset/capture.py)
    DIR/capture/room/                                 with --capture-room: the training views (and every 8th a
                                                      test view) photographed on a floor before two walls, lit
                                                      by the training environment, opaque film: a COLMAP text
                                                      model, JPEGs with EXIF, four at other exposures, the true
                                                      exposures in exposures.json (scripts/dataset/room.py)
"""

import argparse
import json
import os
import shutil
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import blender_kit as kit  # noqa: E402  (also puts the add-on on sys.path)
from dataset import capture, envmaps, exr, png, room, scene as dscene, splat, textures  # noqa: E402
from dataset import shapes as dscene_shapes  # noqa: E402
from ptir_blender.blender import compat  # noqa: E402


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="make_dataset.py", description=__doc__.split("\n")[0])
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--blend", help="take the object from this .blend (collection PTIR_Object)")
    p.add_argument("--res", type=int, default=100, help="image width and height (default 100)")
    p.add_argument("--train", type=int, default=16, help="training views (default 16)")
    p.add_argument("--test", type=int, default=8, help="test views (default 8)")
    p.add_argument("--spp", type=int, default=64, help="Cycles samples per pixel (default 64)")
    p.add_argument("--bounces", type=int, default=4, help="Cycles bounce limit (default 4)")
    p.add_argument("--subdiv", type=int, default=2, help="built-in sample: Suzanne's subdivision level (default 2)")
    p.add_argument("--train-env", default="studio", help="environment of the training and NVS test views")
    p.add_argument("--relight-envs", default="sunset,sky", help="comma-separated relight environments ('' for none)")
    p.add_argument("--env-size", default="128x64", help="environment map size WxH (default 128x64)")
    p.add_argument("--threads", type=int, default=0, help="Cycles threads (0: all)")
    p.add_argument("--save-blend", help="also save the object scene (no cameras/world) to this .blend")
    p.add_argument("--textured", action="store_true", help="noise-textured base colour and roughness per polygon")
    p.add_argument("--metal-fraction", type=float, default=0.0, help="with --textured: fraction of metallic polygons")
    p.add_argument("--metal-layout", default="patches", choices=textures.METAL_LAYOUTS,
                   help="with --metal-fraction: small patches of a three-frequency noise, or a few large regions "
                        "(parts, as an artist paints metal; docs/family.md)")
    p.add_argument("--texture-seed", type=int, default=1, help="with --textured: the pattern's seed")
    p.add_argument("--texture-kind", default="smooth", choices=textures.KINDS,
                   help="with --textured: smooth noise, sharp-edged two tones, high-frequency noise or per-face cells")
    p.add_argument("--roughness-range", default="0.1,0.9", help="with --textured: the roughness pattern's LO,HI")
    p.add_argument("--neutral", action="store_true", help="with --textured: grey albedos (each colour's mean)")
    p.add_argument("--shape", choices=sorted(dscene_shapes.SHAPES),
                   help="a family object built in code (scripts/dataset/shapes.py) instead of the sample")
    p.add_argument("--capture-layouts", action="store_true",
                   help="also write the views as a capture in every layout (DIR/capture/: NeRF, COLMAP bin and txt "
                        "with an OPENCV lens, nerfstudio)")
    p.add_argument("--capture-room", action="store_true",
                   help="also photograph the views as a real capture (DIR/capture/room/: the object on a floor before "
                        "two walls, opaque film, JPEGs with EXIF, a few at other exposures, COLMAP text model)")
    a = p.parse_args(argv)
    a.relight_envs = [e for e in a.relight_envs.split(",") if e]
    try:
        a.roughness_range = tuple(float(v) for v in a.roughness_range.split(","))
        assert len(a.roughness_range) == 2 and 0.0 <= a.roughness_range[0] <= a.roughness_range[1] <= 1.0
    except (ValueError, AssertionError):
        p.error("--roughness-range must be LO,HI with 0 <= LO <= HI <= 1")
    if a.shape and a.blend:
        p.error("--shape and --blend are exclusive")
    for name in [a.train_env] + a.relight_envs:
        if name not in envmaps.PRESETS:
            p.error("unknown environment '%s' (choose from %s)" % (name, ", ".join(envmaps.PRESETS)))
    if a.train_env in a.relight_envs:
        p.error("the training environment cannot also be a relight environment")
    try:
        a.env_w, a.env_h = (int(v) for v in a.env_size.lower().split("x"))
    except ValueError:
        p.error("--env-size must be WxH, e.g. 128x64")
    if min(a.res, a.train, a.spp, a.env_w, a.env_h) < 1 or a.test < 1 or a.bounces < 0:
        p.error("sizes and counts must be positive")
    if a.capture_room and a.test < -(-a.train // 7):
        p.error("--capture-room holds out every 8th photo, one of the test views: %d training views need --test %d "
                "or more" % (a.train, -(-a.train // 7)))
    return a


def log(msg):
    print("make_dataset: " + msg, flush=True)


# ---------------------------------------------------------------- cameras

def train_poses(n, distance):
    """n views spread over the upper part of a sphere (elevation 5..65 degrees, golden-angle azimuths)."""
    out = []
    s0, s1 = np.sin(np.radians(5.0)), np.sin(np.radians(65.0))
    for i in range(n):
        el = np.arcsin(s0 + (s1 - s0) * (i + 0.5) / n)
        az = np.radians(137.50776 * i + 10.0)
        eye = distance * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
        out.append(kit.look_at(eye))
    return out


def test_poses(n, distance):
    """n views on a ring, elevations alternating 15 and 35 degrees, azimuths between the training ones."""
    out = []
    for j in range(n):
        el = np.radians(15.0 if j % 2 == 0 else 35.0)
        az = np.radians(360.0 * j / n + 22.5) - 0.5 * np.pi
        eye = distance * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
        out.append(kit.look_at(eye))
    return out


def write_transforms(path, prefix, poses, res):
    """NeRF-synthetic cameras, with "ptir_brdf": the engine model of the Principled BSDF that Cycles rendered
    the images with (principled-v1 in Blender 3.x, principled-v2 from 4.0 on; the engine's default --brdf)."""
    frames = [{"file_path": "./%s_%03d/rgba" % (prefix, i), "transform_matrix": np.round(m, 7).tolist()}
              for i, m in enumerate(poses)]
    with open(path, "w") as f:
        json.dump({"camera_angle_x": dscene.FOV_X, "w": res, "h": res, "ptir_brdf": compat.principled_model(),
                   "frames": frames}, f, indent=1)


# ---------------------------------------------------------------- passes -> PNG files

def unpremultiply(v, a):
    """Premultiplied pass values / coverage (0 where nothing was hit)."""
    safe = np.where(a > 1e-4, a, 1.0)
    return np.where(a > 1e-4, v / safe, 0.0)


def write_rgba_png(path, rgba):
    """Linear premultiplied RGBA -> straight sRGB-encoded 8-bit RGBA (as Blender and TensoIR store PNGs)."""
    a = rgba[..., 3:4]
    rgb = png.srgb_encode(unpremultiply(rgba[..., :3], a))
    png.write_png(path, png.to_8bit(np.concatenate([rgb, a], -1)))


def write_gt_pngs(view_dir, passes, alpha):
    a = alpha[..., None]
    # Albedo: the "albedo" AOV (base colour x (1 - metallic) of the Principled BSDF),
    # sRGB-encoded colour like TensoIR's albedo.png.
    albedo = png.srgb_encode(unpremultiply(passes["albedo"][..., :3], a))
    png.write_png(os.path.join(view_dir, "albedo.png"), png.to_8bit(np.concatenate([albedo, a], -1)))
    # Normal: world space, 0.5 + 0.5 n (renormalised after the pixel average).
    n = unpremultiply(passes["normal"][..., :3], a)
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
    enc = np.where(a > 1e-4, 0.5 + 0.5 * n, 0.0)
    png.write_png(os.path.join(view_dir, "normal.png"), png.to_8bit(np.concatenate([enc, a], -1)))
    # Roughness: linear grey (data, no curve).
    r = unpremultiply(passes["roughness"][..., :1], a)
    png.write_png(os.path.join(view_dir, "roughness.png"), png.to_8bit(np.concatenate([r, r, r, a], -1)))


def render_view(scene, cam, matrix, seed):
    cam.matrix_world = matrix.T.tolist()  # mathutils takes rows
    scene.cycles.seed = seed
    path = dscene.pass_file(scene)
    if os.path.exists(path):
        os.remove(path)
    bpy.ops.render.render(write_still=True)
    return dscene.read_passes(path, scene.view_layers[0].name)


def render_room(scene, cam, objs, poses, env_file, seed0, coverage):
    """The capture's photos (scripts/dataset/room.py): the floor and walls added, the film opaque,
    every planned view rendered (linear RGB, with the object's coverage of the same view from
    `coverage`); the room removed again. Returns (photos, floor z, floor half width)."""
    named = {s: [("%s_%03d" % (s, i), m) for i, m in enumerate(poses[s])] for s in ("train", "test")}
    views = capture.holdout_plan(named["train"], named["test"])
    parts, floor_z, floor_half = room.build_room(objs)
    kit.set_environment(scene, env_file)
    scene.render.film_transparent = False
    photos = []
    for i, (name, m) in enumerate(views):
        t0 = time.time()
        rgb = render_view(scene, cam, m, seed0 + i + 1)["rgba"][..., :3]
        photos.append(("%03d_%s" % (i, name), m, rgb, coverage[name]))
        log("capture/room/%s (%.1f s)" % (name, time.time() - t0))
    scene.render.film_transparent = True
    for o in parts:
        bpy.data.objects.remove(o, do_unlink=True)
    return photos, floor_z, floor_half


# ---------------------------------------------------------------- splats

def object_splats(objs):
    """Gaussians of every polygon of every object, with per-polygon true materials."""
    dg = bpy.context.evaluated_depsgraph_get()
    pieces, inexact = [], set()
    for o in objs:
        loops, start, total, mat_idx = splat.world_polygons(o, dg)
        if len(start) == 0:
            continue
        g, keep = splat.polygons_to_gaussians(loops, start, total)
        per_polygon = textures.polygon_materials(o)
        if per_polygon is not None:  # textured: each Gaussian takes its polygon's values
            albedo, rough, metal = (v[keep] for v in per_polygon)
            # The oracle's albedo is the base colour (the engine's material reads it so: a metal's F0
            # is its base colour); its Diffuse Color, base x (1 - metallic), is what the eval scores.
            g["albedo"] = albedo
            g["roughness"], g["metallic"] = rough, metal
            g["display_colour"] = png.srgb_encode(albedo)
            pieces.append(g)
            continue
        mats = [s.material for s in o.material_slots] or [None]
        vals = []
        for m in mats:
            c, r, mt, exact = dscene.material_values(m)
            if not exact:
                inexact.add(m.name if m else "(none)")
            vals.append((c, r, mt))
        idx = np.clip(mat_idx[keep], 0, len(vals) - 1)
        base = np.array([v[0] for v in vals])[idx]
        g["albedo"] = base  # the base colour (as above)
        g["roughness"] = np.array([v[1] for v in vals])[idx]
        g["metallic"] = np.array([v[2] for v in vals])[idx]
        g["display_colour"] = png.srgb_encode(base)  # what a trainer's SH DC would roughly hold
        pieces.append(g)
    if not pieces:
        raise RuntimeError("the object has no polygons")
    g = {k: np.concatenate([p[k] for p in pieces]) for k in pieces[0]}
    return g, sorted(inexact)


# ---------------------------------------------------------------- main

def main():
    a = parse_args()
    t_start = time.time()
    out = os.path.abspath(a.out)
    os.makedirs(out, exist_ok=True)
    if a.blend:
        bpy.ops.wm.open_mainfile(filepath=os.path.abspath(a.blend))
        objs = dscene.object_meshes()
        for o in objs:
            for s in o.material_slots:
                if s.material and compat.uses_nodes(s.material):
                    dscene.ensure_aovs(s.material)
        # The environment is the only light: the file's lamps and emitters are not part of the dataset.
        lamps = [o for o in bpy.context.scene.objects if o.type == "LIGHT" and not o.hide_render]
        for o in lamps:
            o.hide_render = True
        if lamps:
            log("the file's %d light(s) are switched off (the environment lights the dataset)" % len(lamps))
        scale, centre = dscene.normalise_objects(objs, 1.25)
        if abs(scale - 1.0) > 1e-4 or np.abs(centre).max() > 1e-4:
            log("object moved by %s and scaled by %.4g into the radius-1.25 sphere at the origin"
                % (np.round(-centre, 4).tolist(), scale))
        source = os.path.abspath(a.blend)
    elif a.shape:
        dscene.clear_scene()
        objs = dscene_shapes.build_shape(a.shape)
        source = "family shape '%s' (scripts/dataset/shapes.py)" % a.shape
    else:
        dscene.clear_scene()
        objs = dscene.build_sample_object(subdiv=a.subdiv)
        source = "built-in sample (subdiv %d)" % a.subdiv
    if not objs:
        raise RuntimeError("no mesh objects to capture")
    if a.textured:
        textures.texture_objects(objs, dscene.material_values, seed=a.texture_seed, metal_fraction=a.metal_fraction,
                                 metal_layout=a.metal_layout, kind=a.texture_kind, roughness_range=a.roughness_range, neutral=a.neutral)
        log("textured (%s%s): per-polygon pattern in base colour and roughness %g..%g%s" %
            (a.texture_kind, ", neutral" if a.neutral else "", a.roughness_range[0], a.roughness_range[1],
             ", metallic patches on %.0f%%" % (100 * a.metal_fraction) if a.metal_fraction > 0 else ""))
    if a.save_blend:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(a.save_blend), compress=True, copy=True)
        log("saved %s" % a.save_blend)
    scene = bpy.context.scene

    # Environment maps (exact linear floats, written byte by byte).
    env_dir = os.path.join(out, "envmaps")
    os.makedirs(env_dir, exist_ok=True)
    env_files = {}
    for name in [a.train_env] + a.relight_envs:
        env_files[name] = os.path.join(env_dir, name + ".exr")
        exr.write_exr(env_files[name], envmaps.make_envmap(name, a.env_w, a.env_h))

    # Cameras.
    distance = 4.0
    poses = {"train": train_poses(a.train, distance), "test": test_poses(a.test, distance)}
    for split in ("train", "test"):
        write_transforms(os.path.join(out, "transforms_%s.json" % split), split, poses[split], a.res)

    # Renders.
    tmp = os.path.join(out, ".passes")
    os.makedirs(tmp, exist_ok=True)
    dscene.setup_cycles(scene, a.res, a.spp, a.bounces, a.threads)
    dscene.setup_passes(scene, tmp)
    cam = dscene.camera_object(scene)
    t_render = time.time()
    n_renders = 0
    jobs = [(a.train_env, "train"), (a.train_env, "test")] + [(e, "test") for e in a.relight_envs]
    f = 0.5 * a.res / np.tan(0.5 * dscene.FOV_X)
    intrinsics = (f, f, 0.5 * a.res, 0.5 * a.res)
    train_env_map = envmaps.make_envmap(a.train_env, a.env_w, a.env_h)
    capture_views = []
    coverage = {}  # view name ("train_003") -> the object's alpha under the training environment (the room's true masks)
    for env, split in jobs:
        kit.set_environment(scene, env_files[env])
        for i, m in enumerate(poses[split]):
            view_dir = os.path.join(out, "%s_%03d" % (split, i))
            os.makedirs(view_dir, exist_ok=True)
            t0 = time.time()
            seed = n_renders + 1
            passes = render_view(scene, cam, m, seed)
            n_renders += 1
            rgba = passes["rgba"]
            name = "rgba.png" if env == a.train_env else "rgba_%s.png" % env
            write_rgba_png(os.path.join(view_dir, name), rgba)
            if split == "test" and env == a.train_env:
                write_gt_pngs(view_dir, passes, rgba[..., 3])
            if env == a.train_env:
                coverage["%s_%03d" % (split, i)] = rgba[..., 3]
            if a.capture_layouts and env == a.train_env:
                photo = capture.composite_over_environment(rgba, m, intrinsics, train_env_map)
                capture_views.append(("%s_%03d" % (split, i), m, photo, rgba[..., 3]))
            log("%s_%03d/%s (%.1f s)" % (split, i, name, time.time() - t0))
    room_photos = render_room(scene, cam, objs, poses, env_files[a.train_env], n_renders, coverage) if a.capture_room else None
    shutil.rmtree(tmp, ignore_errors=True)
    render_s = time.time() - t_render
    if a.capture_layouts:
        made = capture.write_capture_layouts(os.path.join(out, "capture"), capture_views, intrinsics,
                                             extra={"ptir_brdf": compat.principled_model()})
        log("capture layouts: " + ", ".join(sorted(made)))

    # The surface as Gaussians, and the oracle result.
    g, inexact = object_splats(objs)
    splat.write_gaussians_ply(os.path.join(out, "gaussians.ply"), g)
    os.makedirs(os.path.join(out, "oracle"), exist_ok=True)
    splat.write_gaussians_ply(os.path.join(out, "oracle", "gaussians.ply"), g, oracle=True)
    shutil.copyfile(env_files[a.train_env], os.path.join(out, "oracle", "env.exr"))
    if inexact:
        log("warning: materials not exactly representable in the oracle (textured or not Principled): "
            + ", ".join(inexact))

    parts = {}
    for o in objs:
        for s in o.material_slots:
            if s.material and s.material.name not in parts:
                if s.material.get("ptir_face_textured"):
                    parts[s.material.name] = {"textured": "per-polygon face attributes (scripts/dataset/textures.py)"}
                    continue
                c, r, mt, exact = dscene.material_values(s.material)
                parts[s.material.name] = {"base_color": [round(float(v), 6) for v in c], "roughness": round(float(r), 6),
                                          "metallic": round(float(mt), 6), "exact": exact}
    meta = {
        "format": "ptir-dataset/1",
        "generator": "scripts/make_dataset.py (Blender %s, Cycles)" % bpy.app.version_string,
        "ptir_brdf": compat.principled_model(),
        "source": source,
        "resolution": [a.res, a.res],
        "train_views": a.train, "test_views": a.test,
        "cycles": {"spp": a.spp, "bounces": a.bounces, "pixel_filter": {"type": "box", "width": 1.0}, "film": "transparent"},
        "train_env": a.train_env,
        "relight_envs": a.relight_envs,
        "envmaps": {k: os.path.relpath(v, out) for k, v in env_files.items()},
        "env_size": [a.env_w, a.env_h],
        "gaussians": int(len(g["position"])),
        "bbox": [np.round(g["position"].min(0), 5).tolist(), np.round(g["position"].max(0), 5).tolist()],
        "splat": "gaussians.ply",
        "oracle": "oracle",
        "materials": parts,
        "textured": {"seed": a.texture_seed, "metal_fraction": a.metal_fraction, "metal_layout": a.metal_layout,
                     "kind": a.texture_kind,
                     "roughness_range": list(a.roughness_range), "neutral": a.neutral} if a.textured else None,
        "encodings": {"rgba": "sRGB 8-bit, straight alpha = coverage",
                      "albedo": "sRGB 8-bit (AOV: base colour x (1 - metallic)), alpha = coverage",
                      "roughness": "linear 8-bit grey, alpha = coverage",
                      "normal": "world space, 0.5 + 0.5 n, 8-bit, alpha = coverage"},
    }
    with open(os.path.join(out, "dataset.json"), "w") as f:
        json.dump(meta, f, indent=1)
    if a.capture_layouts:  # each capture carries the set's record (surface model, pixel filter), as a converted set does
        for folder in made.values():
            shutil.copyfile(os.path.join(out, "dataset.json"), os.path.join(folder, "dataset.json"))
    if room_photos is not None:
        photos, floor_z, floor_half = room_photos
        record = dict(meta, cycles=dict(meta["cycles"], film="opaque (floor and walls in view)"))
        folder = room.write_capture(os.path.join(out, "capture", "room"), photos, intrinsics, a.res,
                                    room.sparse_points(g["position"], floor_z, floor_half), record, floor_z)
        log("room capture: %d photos -> %s" % (len(photos), folder))
    log("%d Gaussians, %d train + %d test views (%dx%d, %d spp, %d bounces), envs %s; %d renders in %.1f s, total %.1f s -> %s"
        % (len(g["position"]), a.train, a.test, a.res, a.res, a.spp, a.bounces, ",".join(env_files), n_renders,
           render_s, time.time() - t_start, out))


if __name__ == "__main__":
    kit.run_main(main, "make_dataset")
