"""Cycles reference measurements for PTIR's light units and environment orientation.

Run inside Blender (3.4+; bpy 4.5 / 5.0 through tests/blender/bpy_run.py), headless:

    blender -b --factory-startup -noaudio --python-exit-code 1 \
        -P tests/blender/light_units_reference.py -- --out-dir /tmp/x [--samples 64]

It builds tiny scenes, renders them with Cycles on the CPU (direct light only,
Standard view transform, linear 32-bit EXR), reads each EXR back with Blender
itself and prints ONE line

    PTIR_LIGHT_UNITS_JSON: {...}

with the measured values. It computes no expected values: the pytest
(tests/python/test_light_units.py) compares them with the closed forms of
native/src/ptir/lights/light_units.h.

Measurements
  "lambert": mean linear RGB seen by an orthographic camera looking straight
      down at a large white-ish Diffuse BSDF plane (albedo 0.8) at z = 0, lit by
      one light (or the world) only.
  "env": colour seen by a narrow perspective camera at the origin looking along a
      given world direction, with the world = Environment Texture (Closest
      interpolation) of a "texel-coded" map: texel (col, row) -- row 0 = top row
      of the file -- has RGB = ((col+.5)/W, (row+.5)/H, 0.25). An optional Mapping
      node (type POINT, Z rotation) sits in front of the texture, and the
      Background node has a strength.
"""

import argparse
import json
import math
import os
import sys
import time

import bpy

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                                "scripts"))
import blender_kit as kit  # noqa: E402

ALBEDO = 0.8
ENV_W, ENV_H = 16, 8


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser()
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("--samples", type=int, default=64)
    ap.add_argument("--res", type=int, default=16)
    return ap.parse_args(argv)


def setup_render(scene, res, samples):
    """Cycles, direct light only (camera ray -> surface -> light sample / BSDF ray to the light), EXR."""
    kit.plain_cycles(scene, res, samples, threads=max(1, min(2, os.cpu_count() or 1)))
    cy = scene.cycles
    cy.seed = 1
    cy.max_bounces = 0
    cy.diffuse_bounces = 0
    cy.glossy_bounces = 0
    cy.transmission_bounces = 0
    cy.volume_bounces = 0
    cy.transparent_max_bounces = 0
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    cy.filter_width = 1.5
    kit.exr_output(scene)


def add_plane(scene):
    bpy.ops.mesh.primitive_plane_add(size=200.0, location=(0, 0, 0))
    plane = bpy.context.active_object
    mat = bpy.data.materials.new("diffuse_white")
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (ALBEDO, ALBEDO, ALBEDO, 1)
    bsdf.inputs["Roughness"].default_value = 0.0  # Lambertian (no Oren-Nayar)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    plane.data.materials.append(mat)
    return plane


def render_mean(scene, path):
    kit.render_still(scene, path)
    pixels = kit.read_pixels(path)
    h, w, ch = pixels.shape
    px = pixels.ravel().tolist()
    n = w * h
    mean = [sum(px[i * ch + c] for i in range(n)) / n for c in range(3)]
    # Per-pixel spread of the red channel: a noise estimate for the mean.
    reds = [px[i * ch] for i in range(n)]
    var = sum((r - mean[0]) ** 2 for r in reds) / max(1, n - 1)
    return mean, math.sqrt(var / n)


def lambert_cases(args):
    """(name, builder) pairs; builder(scene) adds the light(s) and returns a params dict."""
    def point(scene):
        kit.add_light(scene, "POINT", 100.0, location=(0, 0, 2.0), shadow_soft_size=0.0)
        return {"power": 100.0, "height": 2.0, "radius": 0.0}

    def point_radius(scene):
        kit.add_light(scene, "POINT", 100.0, location=(0, 0, 1.0), shadow_soft_size=0.5)
        return {"power": 100.0, "height": 1.0, "radius": 0.5}

    def area_square(scene):
        kit.add_light(scene, "AREA", 50.0, location=(0, 0, 2.0), shape="SQUARE", size=1.0)
        return {"power": 50.0, "height": 2.0, "size_x": 1.0, "size_y": 1.0}

    def area_rect(scene):
        kit.add_light(scene, "AREA", 80.0, location=(0, 0, 1.5), shape="RECTANGLE", size=2.0,
                  size_y=0.5)
        return {"power": 80.0, "height": 1.5, "size_x": 2.0, "size_y": 0.5}

    def area_disk(scene):
        kit.add_light(scene, "AREA", 50.0, location=(0, 0, 2.0), shape="DISK", size=1.0)
        return {"power": 50.0, "height": 2.0, "diameter": 1.0}

    def sun(scene):
        kit.add_light(scene, "SUN", 3.0, angle=0.0)
        return {"strength": 3.0, "zenith": 0.0}

    def sun_tilted(scene):
        # Rotated 40 degrees about x: the light direction is 40 degrees off vertical.
        kit.add_light(scene, "SUN", 3.0, rotation=(math.radians(40.0), 0, 0), angle=0.0)
        return {"strength": 3.0, "zenith": math.radians(40.0)}

    def sun_angle(scene):
        kit.add_light(scene, "SUN", 3.0, angle=math.radians(60.0))
        return {"strength": 3.0, "zenith": 0.0, "angle": math.radians(60.0)}

    def world(scene):
        bg = scene.world.node_tree.nodes["Background"]
        bg.inputs["Color"].default_value = (1, 1, 1, 1)
        bg.inputs["Strength"].default_value = 1.5
        return {"strength": 1.5, "colour": 1.0}

    return [("point", point), ("point_radius", point_radius), ("area_square", area_square),
            ("area_rect", area_rect), ("area_disk", area_disk), ("sun", sun),
            ("sun_tilted", sun_tilted), ("sun_angle", sun_angle), ("world", world)]


def env_texel(col, row):
    return ((col + 0.5) / ENV_W, (row + 0.5) / ENV_H, 0.25)


def make_env_image(path):
    kit.write_rgbe_texels(path, ENV_W, ENV_H, env_texel)


# (Mapping-node Z rotation in radians, Background strength) pairs.
ENV_SETTINGS = ((0.0, 1.0), (1.0, 2.0), (-1.3, 0.5))


def env_directions():
    """World directions (azimuth, elevation in degrees) used for the orientation check.

    Chosen so that, for every ENV_SETTINGS rotation, each direction falls at least
    0.05 texel away from a texel edge (the pytest checks this), while the camera's
    field of view is 0.5 degrees (0.02 texel), so every pixel sees one texel."""
    return [(0.0 + 8.0, 3.0), (90.0 + 8.0, 3.0), (-90.0 + 8.0, 3.0), (180.0 - 8.0, 3.0),
            (35.0, 50.0), (-130.0, -40.0), (60.0, 80.0), (-20.0, -75.0)]


def env_case(args, scene, env_path, azimuth, elevation, rotation_z, strength, idx):
    # camera rays only: no importance map to build
    kit.set_environment(scene, env_path, rotation_z, strength, sampling="NONE")
    az, el = math.radians(azimuth), math.radians(elevation)
    d = (math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el))
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob, do_unlink=True)
    kit.add_camera(scene, (0, 0, 0), d, fov_x=math.radians(0.5), name="cam")
    mean, _ = render_mean(scene, os.path.join(args.out_dir, "env_%02d.exr" % idx))
    return {"direction": list(d), "rotation_z": rotation_z, "strength": strength, "rgb": mean}


def main():
    args = parse_args()
    os.makedirs(args.out_dir, exist_ok=True)
    t0 = time.time()
    result = {"blender": bpy.app.version_string, "blender_version": list(bpy.app.version), "albedo": ALBEDO, "samples": args.samples,
              "lambert": {}, "env": [], "env_size": [ENV_W, ENV_H]}

    for name, build in lambert_cases(args):
        scene = kit.reset_scene()
        setup_render(scene, args.res, args.samples)
        add_plane(scene)
        kit.add_camera(scene, (0, 0, 5.0), (0, 0, -1), ortho_scale=0.05, name="cam")
        params = build(scene)
        mean, sem = render_mean(scene, os.path.join(args.out_dir, name + ".exr"))
        result["lambert"][name] = {"params": params, "rgb": mean, "sem": sem}

    scene = kit.reset_scene()
    setup_render(scene, 4, 4)
    env_path = os.path.join(args.out_dir, "env_coded.hdr")
    make_env_image(env_path)
    idx = 0
    for rotation_z, strength in ENV_SETTINGS:
        for az, el in env_directions():
            result["env"].append(env_case(args, scene, env_path, az, el, rotation_z, strength, idx))
            idx += 1

    result["seconds"] = time.time() - t0
    print("PTIR_LIGHT_UNITS_JSON: " + json.dumps(result))
    sys.stdout.flush()


if __name__ == "__main__":
    kit.run_main(main)
