"""Blender side of the dataset maker: the sample object, materials with a
roughness AOV, the camera, Cycles settings and the compositor that writes every
pass as an uncompressed float EXR (the environment world and look_at are
scripts/blender_kit.py's).
"""

import math
import os

import blender_kit as kit
import bpy
import numpy as np

OBJECT_COLLECTION = "PTIR_Object"
ROUGHNESS_AOV = "roughness"
FOV_X = 0.6911112  # NeRF-synthetic's camera_angle_x

# The bundled sample: part -> (linear base colour, roughness). Metallic 0 everywhere.
SAMPLE_PARTS = {
    "head": ((0.80, 0.30, 0.10), 0.30),
    "eyes": ((0.85, 0.85, 0.80), 0.20),
    "pedestal_top": ((0.60, 0.60, 0.55), 0.80),
    "pedestal_side": ((0.08, 0.30, 0.45), 0.50),
}


# ---------------------------------------------------------------- materials

def principled_material(name, base_colour, roughness, metallic=0.0):
    """A Principled BSDF (GGX, specular 0.5 = F0 0.04, nothing else) plus an AOV
    Output writing the roughness into the view layer's "roughness" AOV."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    p = nt.nodes["Principled BSDF"]
    p.distribution = "GGX"
    p.inputs["Base Color"].default_value = (*base_colour, 1.0)
    p.inputs["Metallic"].default_value = metallic
    p.inputs["Specular"].default_value = 0.5
    p.inputs["Specular Tint"].default_value = 0.0
    p.inputs["Roughness"].default_value = roughness
    p.inputs["Sheen"].default_value = 0.0
    p.inputs["Clearcoat"].default_value = 0.0
    p.inputs["Subsurface"].default_value = 0.0
    p.inputs["Transmission"].default_value = 0.0
    mat.diffuse_color = (*base_colour, 1.0)  # viewport colour
    mat["ptir_base_color"] = list(base_colour)
    mat["ptir_roughness"] = float(roughness)
    mat["ptir_metallic"] = float(metallic)
    ensure_roughness_aov(mat)
    return mat


def principled_node(mat):
    if not mat or not mat.use_nodes:
        return None
    for node in mat.node_tree.nodes:
        if node.type == "BSDF_PRINCIPLED":
            return node
    return None


def ensure_roughness_aov(mat):
    """Adds (once) an AOV Output "roughness" fed by the Principled node's roughness
    (its link when it is textured, else its value). Materials without a Principled
    node write 0.5 and are reported by material_values()."""
    nt = mat.node_tree
    for node in nt.nodes:
        if node.bl_idname == "ShaderNodeOutputAOV" and node.name == ROUGHNESS_AOV:
            return node
    aov = nt.nodes.new("ShaderNodeOutputAOV")
    aov.name = ROUGHNESS_AOV  # ShaderNodeOutputAOV.name is the AOV's name
    p = principled_node(mat)
    if p is None:
        aov.inputs["Value"].default_value = 0.5
    elif p.inputs["Roughness"].is_linked:
        nt.links.new(p.inputs["Roughness"].links[0].from_socket, aov.inputs["Value"])
    else:
        aov.inputs["Value"].default_value = p.inputs["Roughness"].default_value
    return aov


def material_values(mat):
    """(base colour, roughness, metallic, exact) of a material: the Principled node's
    unlinked values; exact = False when textured or not Principled."""
    if mat is not None and "ptir_base_color" in mat:
        return tuple(mat["ptir_base_color"]), float(mat["ptir_roughness"]), float(mat["ptir_metallic"]), True
    p = principled_node(mat)
    if p is None:
        return (0.8, 0.8, 0.8), 0.5, 0.0, False
    linked = any(p.inputs[k].is_linked for k in ("Base Color", "Roughness", "Metallic"))
    c = p.inputs["Base Color"].default_value
    return (c[0], c[1], c[2]), p.inputs["Roughness"].default_value, p.inputs["Metallic"].default_value, not linked


# ---------------------------------------------------------------- the sample object

def clear_scene():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    for coll in (bpy.data.meshes, bpy.data.materials, bpy.data.cameras, bpy.data.lights, bpy.data.images):
        for block in list(coll):
            coll.remove(block)


def _collection():
    coll = bpy.data.collections.get(OBJECT_COLLECTION)
    if coll is None:
        coll = bpy.data.collections.new(OBJECT_COLLECTION)
        bpy.context.scene.collection.children.link(coll)
    return coll


def _move_to(obj, coll):
    for c in list(obj.users_collection):
        c.objects.unlink(obj)
    coll.objects.link(obj)


def build_sample_object(subdiv=2, pedestal_cuts=4, radius=1.25):
    """Suzanne (smooth, Catmull-Clark level `subdiv`; head and eyes separate parts)
    resting on a closed box pedestal (top and sides separate parts), scaled so the
    bounding sphere of the whole has `radius` and centred at the origin.
    Returns the mesh objects (in collection PTIR_Object)."""
    coll = _collection()
    mats = {name: principled_material(name, c, r) for name, (c, r) in SAMPLE_PARTS.items()}

    size, height = 1.25, 0.4
    ped = kit.add_pedestal(size, height, -0.5 * height, mats["pedestal_top"], mats["pedestal_side"], pedestal_cuts)

    bpy.ops.mesh.primitive_monkey_add(size=1.5, location=(0.0, 0.0, 0.0))
    head = bpy.context.active_object
    head.rotation_euler = (math.radians(-10.0), 0.0, math.radians(-20.0))
    bpy.ops.object.transform_apply(rotation=True)
    lowest = min(v.co.z for v in head.data.vertices)
    head.location.z = -lowest - 0.03  # sink the chin slightly into the pedestal top
    bpy.ops.object.transform_apply(location=True)
    parts = kit.separate_suzanne(mats.get, subdiv, smooth_shading=True)

    objs = [ped] + parts
    for o in objs:
        _move_to(o, coll)
    normalise_objects(objs, radius)
    bpy.ops.object.select_all(action="SELECT")
    bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)
    bpy.ops.object.select_all(action="DESELECT")
    return objs


def world_points(objs):
    """World-space vertices of the evaluated (modifiers applied) meshes."""
    dg = bpy.context.evaluated_depsgraph_get()
    pts = []
    for o in objs:
        ev = o.evaluated_get(dg)
        m = ev.to_mesh()
        co = np.empty(len(m.vertices) * 3)
        m.vertices.foreach_get("co", co)
        ev.to_mesh_clear()
        mw = np.array(ev.matrix_world)
        pts.append(co.reshape(-1, 3) @ mw[:3, :3].T + mw[:3, 3])
    return np.concatenate(pts) if pts else np.zeros((0, 3))


def normalise_objects(objs, radius=1.25):
    """Moves and uniformly scales the objects (through their top-level parents) so that
    the whole fits a sphere of `radius` about the origin, centred on its bounding box.
    Returns (scale, centre before)."""
    from mathutils import Matrix
    pts = world_points(objs)
    if len(pts) == 0:
        return 1.0, np.zeros(3)
    centre = 0.5 * (pts.min(0) + pts.max(0))
    extent = np.linalg.norm(pts - centre, axis=1).max()
    scale = radius / max(extent, 1e-12)
    if abs(scale - 1.0) < 1e-6 and np.abs(centre).max() < 1e-6:
        return 1.0, centre
    n = Matrix.Diagonal((scale, scale, scale, 1.0)) @ Matrix.Translation((-centre[0], -centre[1], -centre[2]))
    roots = []
    for o in objs:
        r = o
        while r.parent is not None:
            r = r.parent
        if r not in roots:
            roots.append(r)
    for r in roots:
        r.matrix_world = n @ r.matrix_world
    bpy.context.view_layer.update()
    return scale, centre


def object_meshes():
    """The object to capture: the meshes of collection PTIR_Object, else every
    visible mesh object of the scene."""
    coll = bpy.data.collections.get(OBJECT_COLLECTION)
    objs = list(coll.all_objects) if coll else list(bpy.context.scene.objects)
    return [o for o in objs if o.type == "MESH" and not o.hide_render]


# ---------------------------------------------------------------- camera, Cycles

def camera_object(scene, fov_x=FOV_X):
    cam = bpy.data.objects.get("PTIR_Camera")
    if cam is None:
        data = bpy.data.cameras.new("PTIR_Camera")
        cam = bpy.data.objects.new("PTIR_Camera", data)
        scene.collection.objects.link(cam)
    cam.data.type = "PERSP"
    cam.data.sensor_fit = "HORIZONTAL"
    cam.data.angle = fov_x
    cam.data.shift_x = cam.data.shift_y = 0.0
    cam.data.clip_start = 0.01
    cam.data.clip_end = 1000.0
    scene.camera = cam
    return cam


def setup_cycles(scene, res, samples, bounces, threads):
    """Cycles computing the expectation ptir's estimator computes (blender_kit.plain_cycles and
    match_estimator: no denoising, adaptive sampling, clamping, glossy filter or light threshold,
    caustics on, Box filter of 1 px, every bounce limit = bounces), transparent film (alpha =
    coverage), the compositor on (it writes the passes), no shadow terminator offsets."""
    kit.plain_cycles(scene, res, samples, threads, transparent=True, compositing=True)
    kit.match_estimator(scene, bounces)
    scene.frame_current = 1
    for o in object_meshes():
        o.cycles.shadow_terminator_geometry_offset = 0.0
        o.cycles.shadow_terminator_offset = 0.0


PASSES = ("rgba", "albedo", "normal", "roughness")


def setup_passes(scene, out_dir):
    """Diffuse Color and Normal passes, the roughness AOV, and a File Output node
    writing rgba/albedo/normal/roughness as uncompressed 32-bit EXR into out_dir."""
    vl = scene.view_layers[0]
    vl.use_pass_diffuse_color = True
    vl.use_pass_normal = True
    if ROUGHNESS_AOV not in [a.name for a in vl.aovs]:
        aov = vl.aovs.add()
        aov.name = ROUGHNESS_AOV
        aov.type = "VALUE"
    scene.use_nodes = True
    nt = scene.node_tree
    nt.nodes.clear()
    rl = nt.nodes.new("CompositorNodeRLayers")
    comp = nt.nodes.new("CompositorNodeComposite")
    nt.links.new(rl.outputs["Image"], comp.inputs["Image"])
    fo = nt.nodes.new("CompositorNodeOutputFile")
    fo.base_path = out_dir
    fo.format.file_format = "OPEN_EXR"
    fo.format.color_depth = "32"
    fo.format.exr_codec = "NONE"
    fo.format.color_mode = "RGBA"
    fo.file_slots.clear()
    sources = {"rgba": "Image", "albedo": "DiffCol", "normal": "Normal", "roughness": ROUGHNESS_AOV}
    for name in PASSES:
        fo.file_slots.new(name + "_")
        slot = fo.file_slots[-1]
        slot.use_node_format = False
        slot.format.file_format = "OPEN_EXR"
        slot.format.color_depth = "32"
        slot.format.exr_codec = "NONE"
        slot.format.color_mode = "RGBA" if name == "rgba" else "RGB"
        nt.links.new(rl.outputs[sources[name]], fo.inputs[-1])
    return fo


def pass_file(out_dir, name, frame=1):
    return os.path.join(out_dir, "%s_%04d.exr" % (name, frame))
