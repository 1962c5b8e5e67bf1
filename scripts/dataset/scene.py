"""Blender side of the dataset maker (Blender 3.4, bpy 4.5 and 5.0): the sample object, materials
(Principled BSDF in this Blender's model) with a roughness AOV, the camera, Cycles settings and the
render output that writes every pass into one uncompressed float multilayer EXR (the environment
world and look_at are scripts/blender_kit.py's).
"""

import math
import os

import blender_kit as kit
import bpy
import numpy as np
from ptir_blender.blender import compat  # (blender_kit puts the add-on on sys.path)

OBJECT_COLLECTION = "PTIR_Object"
ROUGHNESS_AOV = "roughness"
ALBEDO_AOV = "albedo"
FOV_X = 0.6911112  # NeRF-synthetic's camera_angle_x

# The bundled sample: part -> (linear base colour, roughness). Metallic 0 everywhere.
SAMPLE_PARTS = {
    "head": ((0.80, 0.30, 0.10), 0.30),
    "eyes": ((0.85, 0.85, 0.80), 0.20),
    "pedestal_top": ((0.60, 0.60, 0.55), 0.80),
    "pedestal_side": ((0.08, 0.30, 0.45), 0.50),
}


# ---------------------------------------------------------------- materials

# The rest of the Principled BSDF, per model: dielectric F0 0.04, no tint, no other layer.
# v1 (3.x): Specular 0.5 = F0 0.08 x 0.5; v2 (4.0+): IOR 1.5 at Specular IOR Level 0.5, white tint,
# Lambert diffuse (Diffuse Roughness 0, 4.3+).
PLAIN_INPUTS = {
    "principled-v1": {"Specular": 0.5, "Specular Tint": 0.0, "Sheen": 0.0, "Clearcoat": 0.0, "Subsurface": 0.0,
                      "Transmission": 0.0},
    "principled-v2": {"IOR": 1.5, "Specular IOR Level": 0.5, "Specular Tint": (1.0, 1.0, 1.0, 1.0),
                      "Diffuse Roughness": 0.0, "Sheen Weight": 0.0, "Coat Weight": 0.0, "Subsurface Weight": 0.0,
                      "Transmission Weight": 0.0},
}


def principled_material(name, base_colour, roughness, metallic=0.0):
    """A Principled BSDF (GGX, dielectric F0 0.04, nothing else: PLAIN_INPUTS of this Blender's
    model) plus an AOV Output writing the roughness into the view layer's "roughness" AOV."""
    mat = bpy.data.materials.new(name)
    nt = compat.ensure_nodes(mat)
    p = nt.nodes["Principled BSDF"]
    p.distribution = "GGX"
    p.inputs["Base Color"].default_value = (*base_colour, 1.0)
    p.inputs["Metallic"].default_value = metallic
    p.inputs["Roughness"].default_value = roughness
    for socket, value in PLAIN_INPUTS[compat.principled_model()].items():
        if p.inputs.get(socket) is not None:  # (Diffuse Roughness: 4.3+)
            p.inputs[socket].default_value = value
    mat.diffuse_color = (*base_colour, 1.0)  # viewport colour
    mat["ptir_base_color"] = list(base_colour)
    mat["ptir_roughness"] = float(roughness)
    mat["ptir_metallic"] = float(metallic)
    ensure_aovs(mat)
    return mat


def principled_node(mat):
    if not mat or not compat.uses_nodes(mat):
        return None
    for node in mat.node_tree.nodes:
        if node.type == "BSDF_PRINCIPLED":
            return node
    return None


GT_LABEL = "PTIR ground truth"  # the nodes ensure_aovs makes


def _aov_output(nt, name):
    node = nt.nodes.new("ShaderNodeOutputAOV")
    node.label = GT_LABEL
    node.name = name  # the AOV's name before 4.0 ...
    if hasattr(node, "aov_name"):
        node.aov_name = name  # ... and its own property from 4.0 on
    return node


def _feed(nt, source_socket, target, default):
    """target <- the link into source_socket when it has one, else default."""
    if source_socket is not None and source_socket.is_linked:
        nt.links.new(source_socket.links[0].from_socket, target)
    else:
        target.default_value = default


def ensure_aovs(mat):
    """AOV Outputs of the ground truth, fed by the Principled node's inputs (their links when textured,
    else their values): "roughness" (Value) and "albedo" (Color: base colour x (1 - metallic), what
    albedo.png holds; Cycles' Diffuse Color pass is that only in 3.x, v2 scales it by the specular
    layer's albedo). Rebuilt on each call (textures.py rewires the inputs). Materials without a
    Principled node write 0.5 and 0.8 grey and are reported by material_values()."""
    nt = mat.node_tree
    for node in list(nt.nodes):
        if node.label == GT_LABEL or (node.bl_idname == "ShaderNodeOutputAOV"
                                      and getattr(node, "aov_name", node.name) in (ROUGHNESS_AOV, ALBEDO_AOV)):
            nt.nodes.remove(node)
    p = principled_node(mat)
    rough = _aov_output(nt, ROUGHNESS_AOV)
    _feed(nt, p.inputs["Roughness"] if p else None, rough.inputs["Value"],
          p.inputs["Roughness"].default_value if p else 0.5)
    albedo = _aov_output(nt, ALBEDO_AOV)
    one_minus = nt.nodes.new("ShaderNodeMath")
    one_minus.label = GT_LABEL
    one_minus.operation = "SUBTRACT"
    one_minus.inputs[0].default_value = 1.0
    _feed(nt, p.inputs["Metallic"] if p else None, one_minus.inputs[1], p.inputs["Metallic"].default_value if p else 0.0)
    scale = nt.nodes.new("ShaderNodeVectorMath")
    scale.label = GT_LABEL
    scale.operation = "SCALE"
    _feed(nt, p.inputs["Base Color"] if p else None, scale.inputs[0],
          tuple(p.inputs["Base Color"].default_value)[:3] if p else (0.8, 0.8, 0.8))
    nt.links.new(one_minus.outputs[0], scale.inputs["Scale"])
    nt.links.new(scale.outputs["Vector"], albedo.inputs["Color"])
    return rough, albedo


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


def _collection(name=OBJECT_COLLECTION):
    coll = bpy.data.collections.get(name)
    if coll is None:
        coll = bpy.data.collections.new(name)
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
# pass -> (its names in the multilayer EXR: 3.x / 4.x, 5.x; its channels in order)
_PASS_CHANNELS = {"rgba": (("Combined",), "RGBA"), "albedo": ((ALBEDO_AOV,), "RGB"),
                  "normal": (("Normal",), "XYZ"), "roughness": ((ROUGHNESS_AOV,), None)}



def render_reference(scene, out_dir, res, samples, bounces, threads):
    """A comparison scene's Cycles reference: setup_cycles on an opaque film, a 32-bit EXR
    OUT_DIR/cycles.exr, its pixels as OUT_DIR/cycles.npy (linear RGB, row 0 = top). Returns the
    render's seconds."""
    import time
    setup_cycles(scene, res, samples, bounces, threads)
    scene.render.film_transparent = False
    scene.render.use_compositing = False
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    path = os.path.join(out_dir, "cycles.exr")
    scene.render.filepath = path
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    seconds = time.time() - t0
    img = bpy.data.images.load(path, check_existing=False)
    px = np.array(img.pixels[:], np.float32).reshape(res, res, 4)[::-1, :, :3]
    bpy.data.images.remove(img)
    np.save(os.path.join(out_dir, "cycles.npy"), np.ascontiguousarray(px))
    return seconds

def setup_passes(scene, out_dir):
    """The Normal pass and the roughness and albedo AOVs, written by every render (no compositor:
    its Python API changed in 5.0) as one multilayer EXR, 32-bit float, uncompressed, in out_dir."""
    vl = scene.view_layers[0]
    vl.use_pass_normal = True
    for name, kind in ((ROUGHNESS_AOV, "VALUE"), (ALBEDO_AOV, "COLOR")):
        if name not in [a.name for a in vl.aovs]:
            aov = vl.aovs.add()
            aov.name = name
            aov.type = kind
    scene.render.use_compositing = False
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):  # 5.0+: multilayer is a media type
        settings.media_type = "MULTI_LAYER_IMAGE"
    settings.file_format = "OPEN_EXR_MULTILAYER"
    settings.color_depth = "32"
    settings.exr_codec = "NONE"
    scene.render.filepath = os.path.join(out_dir, "passes.exr")
    scene.render.use_file_extension = False


def pass_file(scene):
    """The multilayer EXR a still render writes."""
    return bpy.path.abspath(scene.render.filepath)


def read_passes(path, layer):
    """{pass: (H, W, C) float32, row 0 = top} of PASSES from a render's multilayer EXR (view layer `layer`)."""
    from . import exr
    ch = exr.read_exr(path)
    out = {}
    for name, (render_passes, order) in _PASS_CHANNELS.items():
        for render_pass in render_passes:
            prefix = "%s.%s." % (layer, render_pass)
            names = [k for k in ch if k.startswith(prefix)]
            if order is not None:
                names = [prefix + c for c in order]
            if names and all(n in ch for n in names):
                break
        else:
            raise RuntimeError("%s: no %s pass of view layer '%s' (channels %s)" % (
                path, " / ".join(render_passes), layer, sorted(ch)[:16]))
        out[name] = np.stack([ch[n] for n in names], -1)
    return out
