"""Builds sample_blends/cornell_splats.blend: a heterogeneous Cornell box for the PTIR add-on.

    blender -b --factory-startup -noaudio --python-exit-code 1 \
        -P sample_blends/make_cornell_splats.py -- [--out sample_blends/cornell_splats.blend]

Contents (metres, Blender's Z up):
  - mesh walls: floor, ceiling and back wall white, left wall red, right wall green (Principled
    BSDF: base colour, roughness, metallic); the front (camera side) is open
  - a mesh box (a blue-grey block, Principled roughness 0.35) standing on the floor
  - a splat object "Suzanne Splats": Suzanne's surface turned into flat 3D Gaussians, one per face
    (ptir_blender.io.surface_splats, the construction a 3DGS trainer converges to), with PTIR
    materials (albedo, roughness 0.45, metallic 0) as point attributes, standing on a pedestal
  - two area lights (0.5 x 0.5 m, 15 W each) under the ceiling, facing down
  - the world: an Environment Texture (sky.hdr next to the .blend, a procedural sky written
    here with numpy) at strength 0.6, rotated 30 degrees by a Mapping node
  - a camera looking into the box; render engine PTIR at 256 x 256, 64 spp, 3 bounces
The add-on is enabled from the repository (addon/) for the build.
"""

import argparse
import math
import os
import sys

import bmesh
import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(REPO, "addon"))


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.join(HERE, "cornell_splats.blend"))
    ap.add_argument("--subdiv", type=int, default=1, help="Suzanne subdivision level (1: ~2K splats)")
    return ap.parse_args(argv)


def enable_addon():
    import addon_utils
    mod = addon_utils.enable("ptir_blender", default_set=True, handle_error=None)
    if mod is None:
        raise SystemExit("cannot enable ptir_blender from %s" % os.path.join(REPO, "addon"))
    return mod


def clear():
    for coll in (bpy.data.objects, bpy.data.meshes, bpy.data.lights, bpy.data.cameras, bpy.data.materials,
                 bpy.data.images, bpy.data.worlds):
        for item in list(coll):
            coll.remove(item)


def principled(name, colour, roughness, metallic=0.0):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Metallic"].default_value = metallic
    m.diffuse_color = (*colour, 1.0)
    return m


def mesh_object(name, verts, faces, material):
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    me.update()
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    me.materials.append(material)
    return ob


def box(name, centre, size, angle_z, material):
    cx, cy, cz = centre
    sx, sy, sz = (s / 2 for s in size)
    v = [(x, y, z) for z in (-sz, sz) for y in (-sy, sy) for x in (-sx, sx)]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    ob = mesh_object(name, v, faces, material)
    ob.location = (cx, cy, cz)
    ob.rotation_euler = (0, 0, angle_z)
    return ob


def sky_hdr(path, width=256, height=128):
    """A procedural lat-long sky (Blender's orientation: u = azimuth, v = elevation; row 0 = zenith):
    a blue gradient, a warm sun lobe and a dim brown ground, written as Radiance .hdr."""
    from ptir_blender.blender import scene_export
    v = (np.arange(height) + 0.5) / height
    u = (np.arange(width) + 0.5) / width
    elev = (0.5 - v)[:, None] * math.pi  # +pi/2 at the top row
    az = (u - 0.5)[None, :] * 2 * math.pi
    up = np.clip(np.sin(elev), 0, 1)
    sky = np.stack([0.35 + 0.25 * (1 - up), 0.55 + 0.2 * (1 - up), 1.0 + 0 * up], -1) * (elev > 0)[..., None]
    ground = np.array([0.25, 0.2, 0.15]) * (elev <= 0)[..., None]
    d = np.stack([np.cos(elev) * np.cos(az), np.cos(elev) * np.sin(az), np.sin(elev) * np.ones_like(az)], -1)
    sun_dir = np.array([math.cos(0.6) * math.cos(-0.8), math.cos(0.6) * math.sin(-0.8), math.sin(0.6)])
    sun = np.exp(60.0 * (d @ sun_dir - 1.0))[..., None] * np.array([40.0, 32.0, 22.0])
    rgb = sky + ground + sun
    scene_export.write_rgbe(path, rgb)
    return path


def suzanne_splats(context, subdiv):
    """Suzanne's faces as flat Gaussians with PTIR materials; the mesh is discarded."""
    from ptir_blender.blender import splat_object
    from ptir_blender.io import splat_ply, surface_splats
    bpy.ops.mesh.primitive_monkey_add(size=0.7)
    monkey = context.active_object
    bm = bmesh.new()
    bm.from_mesh(monkey.data)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=subdiv, use_grid_fill=True)
    loops = np.array([[v.co.x, v.co.y, v.co.z] for f in bm.faces for v in f.verts])
    total = np.array([len(f.verts) for f in bm.faces])
    bm.free()
    bpy.data.objects.remove(monkey)
    start = np.concatenate([[0], np.cumsum(total)[:-1]])
    g = surface_splats.polygons_to_gaussians(loops, start, total)
    n = len(g["position"])
    d = splat_ply.empty_like_count(n)
    d.position = g["position"].astype(np.float32)
    d.scale = g["scale"].astype(np.float32)
    d.rotation = g["rotation"].astype(np.float32)
    d.opacity = np.full(n, 0.95, np.float32)
    albedo = np.array([0.80, 0.62, 0.35], np.float32)  # a warm gold-ish plaster
    d.albedo = np.tile(albedo, (n, 1))
    d.roughness = np.full(n, 0.45, np.float32)
    d.metallic = np.zeros(n, np.float32)
    d.normal = g["normal"].astype(np.float32)
    display = surface_splats.linear_to_srgb(albedo)
    d.f_dc = np.tile(((display - 0.5) / splat_ply.SH_C0).astype(np.float32), (n, 1))
    d.sh_rest = np.zeros((0, n, 3), np.float32)
    obj = splat_object.create_splat_object(context, d, "Suzanne Splats", collection=context.scene.collection)
    obj.ptir_splat.display_size = 1.0  # these splats are flat discs spread over their faces: 1 sigma reads best
    obj.location = (0.35, 0.25, 0.78)
    obj.rotation_euler = (0, 0, math.radians(-20))
    return obj


def main():
    a = args()
    enable_addon()
    clear()
    context = bpy.context
    scene = context.scene
    white = principled("White Wall", (0.73, 0.73, 0.73), 0.9)
    red = principled("Red Wall", (0.63, 0.065, 0.05), 0.9)
    green = principled("Green Wall", (0.14, 0.45, 0.091), 0.9)
    block = principled("Blue Block", (0.25, 0.32, 0.55), 0.35)
    pedestal = principled("Pedestal", (0.6, 0.6, 0.6), 0.6)
    s = 1.0
    mesh_object("Floor", [(-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)], [(0, 1, 2, 3)], white)
    mesh_object("Ceiling", [(-s, -s, 2), (-s, s, 2), (s, s, 2), (s, -s, 2)], [(0, 1, 2, 3)], white)
    mesh_object("Back Wall", [(-s, s, 0), (s, s, 0), (s, s, 2), (-s, s, 2)], [(0, 1, 2, 3)], white)
    mesh_object("Left Wall", [(-s, -s, 0), (-s, s, 0), (-s, s, 2), (-s, -s, 2)], [(0, 1, 2, 3)], red)
    mesh_object("Right Wall", [(s, -s, 0), (s, -s, 2), (s, s, 2), (s, s, 0)], [(0, 1, 2, 3)], green)
    box("Block", (-0.4, 0.2, 0.45), (0.5, 0.5, 0.9), math.radians(18), block)
    box("Pedestal", (0.35, 0.25, 0.2), (0.45, 0.45, 0.4), math.radians(-20), pedestal)

    for i, x in enumerate((-0.45, 0.45)):
        light = bpy.data.lights.new("Area %d" % (i + 1), "AREA")
        light.shape = "SQUARE"
        light.size = 0.5
        light.energy = 15.0
        ob = bpy.data.objects.new("Area Light %d" % (i + 1), light)
        ob.location = (x, 0.0, 1.98)
        scene.collection.objects.link(ob)  # area lights emit along -Z: facing down

    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    nt = world.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputWorld")
    bg = nt.nodes.new("ShaderNodeBackground")
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    mapping = nt.nodes.new("ShaderNodeMapping")
    coords = nt.nodes.new("ShaderNodeTexCoord")
    out.location, bg.location, env.location, mapping.location, coords.location = \
        (300, 0), (100, 0), (-250, 0), (-450, 0), (-650, 0)
    hdr = sky_hdr(os.path.join(os.path.dirname(os.path.abspath(a.out)), "sky.hdr"))
    env.image = bpy.data.images.load(hdr)
    for name in ("Linear", "Linear Rec.709"):  # Blender 3.x / 4.x name of scene-linear
        try:
            env.image.colorspace_settings.name = name
            break
        except TypeError:
            continue
    mapping.inputs["Rotation"].default_value[2] = math.radians(30.0)
    bg.inputs["Strength"].default_value = 0.6
    nt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    scene.world = world

    suzanne_splats(context, a.subdiv)

    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 35.0
    cam = bpy.data.objects.new("Camera", cam_data)
    cam.location = (0.0, -3.3, 1.0)
    cam.rotation_euler = (math.radians(90.0), 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam

    r = scene.render
    r.engine = "PTIR"
    r.resolution_x = r.resolution_y = 256
    r.resolution_percentage = 100
    r.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    scene.ptir_render.spp = 64
    scene.ptir_render.bounces = 3
    scene.ptir_optimize.splat_object = bpy.data.objects["Suzanne Splats"]
    # Viewport: material preview shows the splat display; camera view.
    for o in bpy.data.objects:
        o.select_set(False)
    bpy.data.objects["Suzanne Splats"].select_set(True)
    context.view_layer.objects.active = bpy.data.objects["Suzanne Splats"]
    bpy.context.preferences.filepaths.save_version = 0  # no .blend1 backup next to the sample
    bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(a.out), compress=True, relative_remap=True)
    print("wrote %s (%d splats)" % (a.out, len(bpy.data.objects["Suzanne Splats"].data.vertices)))


main()
