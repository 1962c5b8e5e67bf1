"""Runs inside Blender (3.4, or bpy 4.5 / 5.0): builds a scene with one of everything and exports it.

    blender -b --factory-startup -noaudio --python-exit-code 1 \
        -P tests/blender/scene_export_check.py -- <out_dir> <gaussians.ply>
    (or tests/blender/bpy_run.py with the bpy venv's python: tests/blender/blenders.py)

The Principled materials are set through this Blender's socket names (3.x: Specular, Emission, ...;
4.0+: Specular IOR Level, Emission Color, ...); "layered" sets every input the exporter reads or
warns about to a value away from its default.

Prints one line "PTIR_EXPORT_JSON: {...}" with the exported scene path, the
exporter's warnings and what Blender itself says about the scene (world-space
bounding boxes, triangle counts, light matrices, where the camera projects test
points), for tests/blender/test_scene_export.py to compare with the file.
"""

import json
import math
import os
import sys
import traceback

import bpy
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "addon"))

from ptir_blender.blender import compat, scene_export  # noqa: E402
from ptir_blender.io import hdr_file  # noqa: E402

V2 = bpy.app.version >= (4, 0, 0)
# Every Principled input "layered" sets: socket -> value, per model (the v2 names from 4.0 on).
LAYERED = ({"IOR": 1.33, "Specular IOR Level": 0.7, "Specular Tint": (0.9, 0.5, 0.2, 1.0), "Coat Weight": 0.3,
            "Sheen Weight": 0.2, "Transmission Weight": 0.1, "Subsurface Weight": 0.05}
           if V2 else {"Specular": 0.7, "Specular Tint": 0.3, "Clearcoat": 0.3, "Sheen": 0.2, "Transmission": 0.1,
                       "Subsurface": 0.05})
if bpy.app.version >= (4, 3, 0):
    LAYERED["Diffuse Roughness"] = 0.4


def clear():
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob, do_unlink=True)


def new_material(name):
    mat = bpy.data.materials.new(name)
    compat.ensure_nodes(mat)
    return mat


def principled(name, base, rough, metal, emission=None, strength=1.0, inputs=None):
    mat = new_material(name)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*base, 1.0)
    bsdf.inputs["Roughness"].default_value = rough
    bsdf.inputs["Metallic"].default_value = metal
    if emission is not None:
        bsdf.inputs["Emission Color" if V2 else "Emission"].default_value = (*emission, 1.0)
        bsdf.inputs["Emission Strength"].default_value = strength
    for k, v in (inputs or {}).items():
        bsdf.inputs[k].default_value = v
    return mat


def diffuse(name, colour):
    mat = new_material(name)
    nt = mat.node_tree
    nt.nodes.remove(nt.nodes["Principled BSDF"])
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (*colour, 1.0)
    nt.links.new(d.outputs["BSDF"], nt.nodes["Material Output"].inputs["Surface"])
    return mat


def emission_only(name, colour, strength):
    mat = new_material(name)
    nt = mat.node_tree
    nt.nodes.remove(nt.nodes["Principled BSDF"])
    e = nt.nodes.new("ShaderNodeEmission")
    e.inputs["Color"].default_value = (*colour, 1.0)
    e.inputs["Strength"].default_value = strength
    nt.links.new(e.outputs["Emission"], nt.nodes["Material Output"].inputs["Surface"])
    return mat


def light(kind, name, energy, location, rotation=(0, 0, 0), scale=(1, 1, 1), **props):
    data = bpy.data.lights.new(name, kind)
    data.energy = energy
    for k, v in props.items():
        setattr(data, k, v)
    ob = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(ob)
    ob.location = location
    ob.rotation_euler = rotation
    ob.scale = scale
    return ob


def main(out_dir, gaussians_ply):
    clear()
    scene = bpy.context.scene
    # A cube with two material slots (top face: emissive Principled; others: Diffuse), rotated,
    # non-uniformly scaled, with a Simple subdivision modifier (exported evaluated).
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(1.0, 2.0, 0.5), rotation=(0.0, 0.0, 0.3))
    cube = bpy.context.active_object
    cube.name = "Cube"
    cube.scale = (1.0, 0.5, 0.25)
    cube.data.materials.append(diffuse("matte", (0.2, 0.4, 0.6)))
    cube.data.materials.append(principled("shiny", (0.9, 0.8, 0.1), 0.35, 1.0, emission=(1.0, 0.5, 0.25),
                                          strength=2.0))
    for p in cube.data.polygons:
        p.material_index = 1 if p.normal.z > 0.9 else 0
    mod = cube.modifiers.new("sub", "SUBSURF")
    mod.subdivision_type = "SIMPLE"
    mod.levels = mod.render_levels = 1
    # A plane with an Emission shader and one hidden from render (skipped).
    bpy.ops.mesh.primitive_plane_add(size=4.0, location=(0.0, 0.0, -1.0))
    plane = bpy.context.active_object
    plane.name = "Lamp plane"
    plane.data.materials.append(emission_only("glow", (0.5, 1.0, 0.25), 4.0))
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(3.0, 0.0, -1.0))
    layered = bpy.context.active_object
    layered.name = "Layered"
    layered.data.materials.append(principled("layered", (0.3, 0.6, 0.2), 0.45, 0.25, inputs=LAYERED))
    layered.data.materials[0].node_tree.nodes["Principled BSDF"].distribution = "GGX"
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(0.0, 0.0, 5.0))
    hidden = bpy.context.active_object
    hidden.name = "Hidden"
    hidden.hide_render = True
    # Gaussians carried by an empty with the custom property.
    holder = bpy.data.objects.new("Splats", None)
    scene.collection.objects.link(holder)
    holder["ptir_gaussians"] = gaussians_ply
    holder.location = (0.0, 0.0, 1.0)
    holder.rotation_euler = (0.0, 0.0, math.radians(90.0))
    holder.scale = (2.0, 2.0, 2.0)
    # Lights.
    light("POINT", "Bulb", 120.0, (1.0, -2.0, 3.0), color=(1.0, 0.8, 0.6), shadow_soft_size=0.2)
    light("SUN", "Sun", 2.5, (0, 0, 10), rotation=(math.radians(30), math.radians(10), 0.0), angle=0.1)
    light("AREA", "Panel", 55.0, (0.0, 0.0, 2.5), rotation=(math.radians(180), 0, 0), scale=(2.0, 1.0, 1.0),
          shape="ELLIPSE", size=0.5, size_y=0.25)
    light("SPOT", "Spot", 10.0, (0, 0, 4))
    # World: Environment Texture of a tiny file + Mapping Z rotation + strength.
    env_path = os.path.join(out_dir, "tiny_env.hdr")
    hdr_file.write_rgbe(env_path, [[[0.5, 0.25, 0.125]] * 4] * 2)
    nt = compat.ensure_nodes(scene.world)
    nt.nodes.clear()
    texco = nt.nodes.new("ShaderNodeTexCoord")
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, 1.25)
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(env_path)
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = 1.75
    out = nt.nodes.new("ShaderNodeOutputWorld")
    nt.links.new(texco.outputs["Generated"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    # Cameras: the scene camera (portrait render, AUTO sensor fit, 50 %) and a second one.
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 300, 500, 50
    cams = {}
    for name, loc, lens in (("Main", (6.0, -7.0, 4.0), 35.0), ("Other", (-5.0, -5.0, 2.0), 50.0)):
        data = bpy.data.cameras.new(name)
        data.lens = lens
        ob = bpy.data.objects.new(name, data)
        scene.collection.objects.link(ob)
        ob.location = loc
        ob.rotation_mode = "QUATERNION"
        ob.rotation_quaternion = (Vector((0.0, 0.0, 0.5)) - Vector(loc)).to_track_quat("-Z", "Y")
        cams[name] = ob
    cams["Main"].scale = (1.5, 1.5, 1.5)  # must not change the rays
    scene.camera = cams["Main"]
    bpy.context.view_layer.update()

    warnings = []
    path = scene_export.export_scene(bpy.context, out_dir, integrator={"spp": 3, "bounces": 1}, warnings=warnings)

    depsgraph = bpy.context.evaluated_depsgraph_get()
    ev = cube.evaluated_get(depsgraph)
    me = ev.to_mesh()
    me.calc_loop_triangles()
    mw = cube.matrix_world
    pts = [mw @ v.co for v in me.vertices]
    tri_mat = [t.material_index for t in me.loop_triangles]
    ev.to_mesh_clear()
    # Where Blender projects some world points in the scene camera (x, y in [0, 1], y up).
    probes = [(0.0, 0.0, 0.5), (1.0, 2.0, 0.5), (-1.5, 1.0, 2.0), (2.0, -1.0, -0.5)]
    proj = [list(world_to_camera_view(scene, cams["Main"], Vector(p))) for p in probes]
    info = {
        "scene": path, "warnings": warnings,
        "cube_bbox": [[min(p[i] for p in pts) for i in range(3)], [max(p[i] for p in pts) for i in range(3)]],
        "cube_tris": [tri_mat.count(0), tri_mat.count(1)],
        "splats_matrix": [list(r) for r in holder.matrix_world],
        "sun_z": list(bpy.data.objects["Sun"].matrix_world.col[2][:3]),
        "panel_matrix": [list(r) for r in bpy.data.objects["Panel"].matrix_world],
        "probes": probes, "projected": proj,
        "main_location": list(cams["Main"].location),
        "blender": list(bpy.app.version), "layered": {k: (list(v) if hasattr(v, "__len__") else v)
                                                       for k, v in LAYERED.items()},
        "distributions": {m.name: m.node_tree.nodes["Principled BSDF"].distribution
                          for m in bpy.data.materials if m.node_tree and "Principled BSDF" in m.node_tree.nodes},
    }
    print("PTIR_EXPORT_JSON: " + json.dumps(info))


if __name__ == "__main__":
    try:
        argv = sys.argv[sys.argv.index("--") + 1:]
        main(argv[0], argv[1])
    except Exception:
        traceback.print_exc()
        print("scene_export_check: FAILED", file=sys.stderr)
        sys.exit(1)
