"""Splat objects in Blender: SplatData <-> a vertex-only mesh with point attributes.

Attribute layout (point domain), after Blender 5.3's native splat names:
    vertex positions   position (object space)
    scale              FLOAT_VECTOR  standard deviations, linear
    rotation           w, x, y, z: QUATERNION (Blender 4.0+) or FLOAT_COLOR (4 floats, Blender 3.x)
    opacity            FLOAT         sigmoid-activated, [0, 1]
    radiance:base      FLOAT_VECTOR  SH DC coefficients f_dc_0..2 (raw, as in the PLY)
    radiance:sh_<k>    FLOAT_VECTOR  higher SH coefficient k (RGB), k = 0 .. 3/8/15/23 for degree 1/2/3/4
PTIR's material, beside them under the ptir_ prefix:
    ptir_albedo        FLOAT_COLOR   linear RGB (alpha 1)
    ptir_roughness     FLOAT
    ptir_metallic      FLOAT
    ptir_normal        FLOAT_VECTOR  object space; zero = none (the engine uses the shortest axis)
Other PLY properties are kept as FLOAT attributes named "ply:<name>".

Everything moves through numpy and foreach_get/foreach_set: no Python loop per splat.

The viewport display is a Geometry Nodes modifier ("PTIR Splat Display") that
instances a low-poly ellipsoid per splat (scaled by its standard deviations,
rotated by its quaternion), showing at most a capped number of splats, coloured
by the SH colour, the albedo, the roughness, the metallic or the normal (the
object's ptir_splat.display setting) through the material "PTIR Splat Display".
"""

import bpy
import numpy as np

from . import compat
from ..io import splat_ply, splat_transform
from ..io.splat_ply import SplatData
from ..errors import SplatObjectError

REQUIRED_ATTRIBUTES = ("scale", "rotation", "opacity")
DISPLAY_GROUP = "PTIR Splat Display"
DISPLAY_MATERIAL = "PTIR Splat Display"
DISPLAY_MODIFIER = "PTIR Splat Display"
DISPLAY_ATTRIBUTE = "ptir_display"
DISPLAY_MODES = ("COLOR", "ALBEDO", "ROUGHNESS", "METALLIC", "NORMAL")
DEFAULT_DISPLAY_LIMIT = 200_000
DEFAULT_DISPLAY_SIZE = 1.5  # ellipsoid radii in standard deviations
# 2: the splat points are kept beside the instances (object bounds); 3: the display value is stored
# on the instances, not on every point
DISPLAY_GROUP_VERSION = 3

HAS_QUATERNION = bpy.app.version >= (4, 0, 0)
ROTATION_TYPE = "QUATERNION" if HAS_QUATERNION else "FLOAT_COLOR"
_KEYS = {"FLOAT": "value", "FLOAT_VECTOR": "vector", "FLOAT_COLOR": "color", "QUATERNION": "value"}
_WIDTH = {"FLOAT": 1, "FLOAT_VECTOR": 3, "FLOAT_COLOR": 4, "QUATERNION": 4}


# ------------------------------------------------------------------ attributes


def _set_attribute(mesh, name, data_type, values):
    n = len(mesh.vertices)
    width = _WIDTH[data_type]
    a = np.ascontiguousarray(values, dtype=np.float32).reshape(n, -1)
    if width == 4 and a.shape[1] == 3:  # colours: alpha 1
        a = np.concatenate([a, np.ones((n, 1), np.float32)], axis=1)
    if a.shape[1] != width:
        raise SplatObjectError("attribute '%s' needs %d values per point, got %d" % (name, width, a.shape[1]))
    attr = mesh.attributes.get(name)
    if attr is not None and (attr.data_type != data_type or attr.domain != "POINT"):
        mesh.attributes.remove(attr)
        attr = None
    if attr is None:
        attr = mesh.attributes.new(name, data_type, "POINT")
    attr.data.foreach_set(_KEYS[data_type], a.ravel())
    return attr


def _get_attribute(mesh, name, width=None, required=True, what="object"):
    attr = mesh.attributes.get(name)
    if attr is None:
        if required:
            raise SplatObjectError("%s: missing point attribute '%s'" % (what, name))
        return None
    if attr.domain != "POINT":
        raise SplatObjectError("%s: attribute '%s' is on the %s domain, expected POINT" % (what, name, attr.domain))
    w = _WIDTH.get(attr.data_type)
    if w is None:
        raise SplatObjectError("%s: attribute '%s' has type %s" % (what, name, attr.data_type))
    n = len(mesh.vertices)
    out = np.empty(n * w, np.float32)
    attr.data.foreach_get(_KEYS[attr.data_type], out)
    out = out.reshape(n, w)
    if width is not None:
        if width == 3 and w == 4:
            out = out[:, :3]
        elif w != width:
            raise SplatObjectError("%s: attribute '%s' has %d components, expected %d" % (what, name, w, width))
    return np.ascontiguousarray(out[:, 0] if width == 1 else out)


def is_splat_mesh(mesh):
    return mesh is not None and all(mesh.attributes.get(n) is not None for n in REQUIRED_ATTRIBUTES)


def is_splat_object(obj):
    """A mesh object carrying the splat attributes (scale, rotation, opacity)."""
    return obj is not None and obj.type == "MESH" and is_splat_mesh(obj.data)


def write_data_to_mesh(mesh, d, keep_positions=False):
    """Writes a SplatData into a mesh (which must have len(d) vertices, or none: they are added)."""
    n = len(d)
    if len(mesh.vertices) == 0:
        mesh.vertices.add(n)
    elif len(mesh.vertices) != n:
        raise SplatObjectError("mesh '%s' has %d vertices, the splats %d" % (mesh.name, len(mesh.vertices), n))
    if not keep_positions:
        mesh.vertices.foreach_set("co", np.ascontiguousarray(d.position, np.float32).ravel())
    _set_attribute(mesh, "scale", "FLOAT_VECTOR", d.scale)
    _set_attribute(mesh, "rotation", ROTATION_TYPE, d.rotation)
    _set_attribute(mesh, "opacity", "FLOAT", d.opacity)
    _set_attribute(mesh, "radiance:base", "FLOAT_VECTOR", d.f_dc)
    K = d.sh_rest.shape[0]
    for k in range(K):
        _set_attribute(mesh, "radiance:sh_%d" % k, "FLOAT_VECTOR", d.sh_rest[k])
    for k in range(K, 24):  # a lower degree than before: drop stale coefficients
        old = mesh.attributes.get("radiance:sh_%d" % k)
        if old is not None:
            mesh.attributes.remove(old)
    write_material_attributes(mesh, d.albedo, d.roughness, d.metallic, d.normal)
    for name, values in d.extra.items():
        _set_attribute(mesh, "ply:" + name, "FLOAT", values)
    mesh.update()


def write_material_attributes(mesh, albedo=None, roughness=None, metallic=None, normal=None):
    if albedo is not None:
        _set_attribute(mesh, "ptir_albedo", "FLOAT_COLOR", albedo)
    if roughness is not None:
        _set_attribute(mesh, "ptir_roughness", "FLOAT", roughness)
    if metallic is not None:
        _set_attribute(mesh, "ptir_metallic", "FLOAT", metallic)
    if normal is not None:
        _set_attribute(mesh, "ptir_normal", "FLOAT_VECTOR", normal)


MATERIAL_CHANNELS = {"albedo": ("ptir_albedo", 3, "DEFAULT_ALBEDO"), "roughness": ("ptir_roughness", 1, "DEFAULT_ROUGHNESS"),
                     "metallic": ("ptir_metallic", 1, "DEFAULT_METALLIC")}


def read_material_channel(mesh, channel, what="object"):
    """One material channel ("albedo" (n, 3), "roughness" or "metallic" (n,)), the engine default where absent."""
    name, width, default = MATERIAL_CHANNELS[channel]
    values = _get_attribute(mesh, name, width, required=False, what=what)
    if values is None:
        n = len(mesh.vertices)
        values = np.full((n, 3) if width == 3 else n, getattr(splat_ply, default), np.float32)
    return values


def read_material_attributes(mesh, what="object"):
    """(albedo (n, 3), roughness (n,), metallic (n,)) of a splat mesh, engine defaults where absent."""
    n = len(mesh.vertices)
    albedo = _get_attribute(mesh, "ptir_albedo", 3, required=False, what=what)
    roughness = _get_attribute(mesh, "ptir_roughness", 1, required=False, what=what)
    metallic = _get_attribute(mesh, "ptir_metallic", 1, required=False, what=what)
    if albedo is None:
        albedo = np.full((n, 3), splat_ply.DEFAULT_ALBEDO, np.float32)
    if roughness is None:
        roughness = np.full(n, splat_ply.DEFAULT_ROUGHNESS, np.float32)
    if metallic is None:
        metallic = np.full(n, splat_ply.DEFAULT_METALLIC, np.float32)
    return albedo, roughness, metallic


def _sync_edit_mode(obj):
    if obj.mode == "EDIT":
        obj.update_from_editmode()


def read_data_from_object(obj, sync_edit_mode=True):
    """The object's splats as a SplatData in object space (raises SplatObjectError naming what is missing).

    sync_edit_mode: in edit mode, first copy the edit-mode data into the mesh (not from a render thread:
    Blender flushes edit-mode data itself before a render starts)."""
    what = "object '%s'" % obj.name
    if obj.type != "MESH":
        raise SplatObjectError("%s is a %s, not a splat mesh" % (what, obj.type.lower()))
    if sync_edit_mode:
        _sync_edit_mode(obj)
    mesh = obj.data
    n = len(mesh.vertices)
    if n == 0:
        raise SplatObjectError("%s has no splats (no vertices)" % what)
    missing = [a for a in REQUIRED_ATTRIBUTES if mesh.attributes.get(a) is None]
    if missing:
        raise SplatObjectError("%s is not a splat object: missing point attributes %s" % (what, ", ".join(missing)))
    co = np.empty(n * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    d = SplatData(position=co.reshape(n, 3),
                  scale=_get_attribute(mesh, "scale", 3, what=what),
                  rotation=_get_attribute(mesh, "rotation", 4, what=what),
                  opacity=_get_attribute(mesh, "opacity", 1, what=what))
    f_dc = _get_attribute(mesh, "radiance:base", 3, required=False, what=what)
    d.f_dc = f_dc if f_dc is not None else np.zeros((n, 3), np.float32)
    K = 0
    for k in (24, 15, 8, 3):
        if mesh.attributes.get("radiance:sh_%d" % (k - 1)) is not None:
            K = k
            break
    d.sh_rest = np.zeros((K, n, 3), np.float32)
    for k in range(K):
        d.sh_rest[k] = _get_attribute(mesh, "radiance:sh_%d" % k, 3, what=what)
    d.albedo, d.roughness, d.metallic = read_material_attributes(mesh, what)
    normal = _get_attribute(mesh, "ptir_normal", 3, required=False, what=what)
    d.normal = normal if normal is not None else np.zeros((n, 3), np.float32)
    d.extra = {}
    for attr in mesh.attributes:
        if attr.name.startswith("ply:") and attr.domain == "POINT" and attr.data_type == "FLOAT":
            d.extra[attr.name[4:]] = _get_attribute(mesh, attr.name, 1, what=what)
    d.has_material = mesh.attributes.get("ptir_albedo") is not None
    d.has_normals = bool(np.all(np.any(d.normal != 0, axis=1)))
    if np.any(d.scale <= 0) or not np.all(np.isfinite(d.scale)):
        raise SplatObjectError("%s: attribute 'scale' has non-positive or non-finite values" % what)
    return d


def world_data(obj, sync_edit_mode=True):
    """The object's splats with its world matrix folded into positions, scales, rotations and normals
    (any invertible affine matrix: io/splat_transform.py has the rule)."""
    d = read_data_from_object(obj, sync_edit_mode)
    return splat_transform.transform_splats(d, np.array(obj.matrix_world, np.float64),
                                            what="object '%s': its transform" % obj.name)


# ------------------------------------------------------------------ objects


def create_splat_object(context, d, name, collection=None, display_limit=DEFAULT_DISPLAY_LIMIT,
                        display_size=DEFAULT_DISPLAY_SIZE, display=True):
    """A new object with a vertex-only mesh holding d; linked into the collection (default: the active one)."""
    mesh = bpy.data.meshes.new(name)
    try:
        write_data_to_mesh(mesh, d)
    except Exception:
        bpy.data.meshes.remove(mesh)
        raise
    obj = bpy.data.objects.new(name, mesh)
    (collection or context.collection).objects.link(obj)
    if display:
        add_display(obj, display_limit, display_size)
    return obj


# ------------------------------------------------------------------ display


def _enabled(sockets, name):
    for s in sockets:
        if s.name == name and getattr(s, "enabled", True):
            return s
    raise KeyError(name)


class _Builder:
    """Small helper to wire a node tree."""

    def __init__(self, tree):
        self.tree, self.nodes, self.links = tree, tree.nodes, tree.links
        self.x = 0

    def node(self, kind, **props):
        n = self.nodes.new(kind)
        for k, v in props.items():
            setattr(n, k, v)
        n.location = (self.x, 0)
        self.x += 40
        return n

    def feed(self, socket, value):
        if isinstance(value, bpy.types.NodeSocket):
            self.links.new(value, socket)
        else:
            socket.default_value = value

    def math(self, op, a, b=None):
        n = self.node("ShaderNodeMath", operation=op)
        self.feed(n.inputs[0], a)
        if b is not None:
            self.feed(n.inputs[1], b)
        return n.outputs[0]

    def vmath(self, op, a, b=None, scale=None):
        n = self.node("ShaderNodeVectorMath", operation=op)
        self.feed(n.inputs[0], a)
        if b is not None:
            self.feed(n.inputs[1], b)
        if scale is not None:
            self.feed(_enabled(n.inputs, "Scale"), scale)
        return _enabled(n.outputs, "Vector")

    def named(self, name, data_type):
        n = self.node("GeometryNodeInputNamedAttribute", data_type=data_type)
        n.inputs["Name"].default_value = name
        return _enabled(n.outputs, "Attribute")

    def combine(self, x, y, z):
        n = self.node("ShaderNodeCombineXYZ")
        for i, v in enumerate((x, y, z)):
            self.feed(n.inputs[i], v)
        return n.outputs[0]

    def separate(self, v):
        n = self.node("ShaderNodeSeparateXYZ")
        self.feed(n.inputs[0], v)
        return n.outputs[0], n.outputs[1], n.outputs[2]


def _group_socket(group, name, in_out, socket_type, default=None, min_value=None, max_value=None):
    if hasattr(group, "interface"):
        item = group.interface.new_socket(name, in_out=in_out, socket_type=socket_type)
    else:
        item = (group.inputs if in_out == "INPUT" else group.outputs).new(socket_type, name)
    if default is not None:
        item.default_value = default
    if min_value is not None:
        item.min_value = min_value
    if max_value is not None:
        item.max_value = max_value
    return item


def _group_inputs(group):
    if hasattr(group, "interface"):
        return [i for i in group.interface.items_tree if getattr(i, "in_out", None) == "INPUT"]
    return list(group.inputs)


def _euler_from_quaternion(b, q):
    """XYZ Euler angles (Blender's order, R = Rz Ry Rx) of a unit quaternion given as an RGBA socket."""
    sep = b.node("FunctionNodeSeparateColor")
    b.feed(sep.inputs[0], q)
    w, x, y, z = sep.outputs["Red"], sep.outputs["Green"], sep.outputs["Blue"], sep.outputs["Alpha"]
    m, two = b.math, 2.0

    def sq(a):
        return m("MULTIPLY", a, a)

    ex = m("ARCTAN2", m("MULTIPLY", two, m("ADD", m("MULTIPLY", w, x), m("MULTIPLY", y, z))),
           m("SUBTRACT", 1.0, m("MULTIPLY", two, m("ADD", sq(x), sq(y)))))
    sin_y = m("MULTIPLY", two, m("SUBTRACT", m("MULTIPLY", w, y), m("MULTIPLY", z, x)))
    ey = m("ARCSINE", m("MINIMUM", m("MAXIMUM", sin_y, -1.0), 1.0))
    ez = m("ARCTAN2", m("MULTIPLY", two, m("ADD", m("MULTIPLY", w, z), m("MULTIPLY", x, y))),
           m("SUBTRACT", 1.0, m("MULTIPLY", two, m("ADD", sq(y), sq(z)))))
    return b.combine(ex, ey, ez)


def display_group():
    """The shared Geometry Nodes group that displays splats (built once per file)."""
    group = bpy.data.node_groups.get(DISPLAY_GROUP)
    if group is not None and group.get("ptir_version") == DISPLAY_GROUP_VERSION:
        return group
    if group is None:
        group = bpy.data.node_groups.new(DISPLAY_GROUP, "GeometryNodeTree")
    else:
        group.nodes.clear()
        if hasattr(group, "interface"):
            group.interface.clear()
        else:
            group.inputs.clear()
            group.outputs.clear()
    group["ptir_version"] = DISPLAY_GROUP_VERSION
    _group_socket(group, "Geometry", "INPUT", "NodeSocketGeometry")
    _group_socket(group, "Fraction", "INPUT", "NodeSocketFloat", 1.0, 0.0, 1.0)
    _group_socket(group, "Size", "INPUT", "NodeSocketFloat", DEFAULT_DISPLAY_SIZE, 0.0, 100.0)
    _group_socket(group, "Mode", "INPUT", "NodeSocketInt", 0, 0, len(DISPLAY_MODES) - 1)
    _group_socket(group, "Material", "INPUT", "NodeSocketMaterial")
    _group_socket(group, "Geometry", "OUTPUT", "NodeSocketGeometry")
    b = _Builder(group)
    gin = b.node("NodeGroupInput")
    gout = b.node("NodeGroupOutput")
    geometry, fraction, size, mode, material = (gin.outputs[i] for i in range(5))

    # Display value for the chosen mode: sum over modes of (mode == m) * value_m.
    c0 = splat_ply.SH_C0
    dc = b.named("radiance:base", "FLOAT_VECTOR")
    srgb = b.vmath("MINIMUM", b.vmath("MAXIMUM", b.vmath("ADD", b.vmath("SCALE", dc, scale=c0), (0.5, 0.5, 0.5)),
                                      (0.0, 0.0, 0.0)), (1.0, 1.0, 1.0))
    r, g, bl = b.separate(srgb)
    colour = b.combine(*(b.math("POWER", ch, 2.2) for ch in (r, g, bl)))  # display -> linear (approx.)
    albedo = b.named("ptir_albedo", "FLOAT_VECTOR")
    rough = b.named("ptir_roughness", "FLOAT")
    metal = b.named("ptir_metallic", "FLOAT")
    normal = b.vmath("ADD", b.vmath("SCALE", b.named("ptir_normal", "FLOAT_VECTOR"), scale=0.5), (0.5, 0.5, 0.5))
    values = [colour, albedo, b.combine(rough, rough, rough), b.combine(metal, metal, metal), normal]
    total = None
    for k, v in enumerate(values):
        eq = b.math("COMPARE", mode, float(k))
        eq_node = eq.node
        eq_node.inputs[2].default_value = 0.25  # epsilon
        term = b.vmath("SCALE", v, scale=eq)
        total = term if total is None else b.vmath("ADD", total, term)

    rnd = b.node("FunctionNodeRandomValue", data_type="BOOLEAN")
    b.feed(_enabled(rnd.inputs, "Probability"), fraction)
    _enabled(rnd.inputs, "Seed").default_value = 7

    ico = b.node("GeometryNodeMeshIcoSphere")
    ico.inputs["Radius"].default_value = 1.0
    ico.inputs["Subdivisions"].default_value = 1
    setmat = b.node("GeometryNodeSetMaterial")
    b.feed(setmat.inputs["Geometry"], ico.outputs[0])
    b.feed(setmat.inputs["Material"], material)

    inst = b.node("GeometryNodeInstanceOnPoints")
    b.feed(inst.inputs["Points"], geometry)
    b.feed(inst.inputs["Selection"], _enabled(rnd.outputs, "Value"))
    b.feed(inst.inputs["Instance"], setmat.outputs[0])
    if HAS_QUATERNION:
        b.feed(inst.inputs["Rotation"], b.named("rotation", "QUATERNION"))
    else:
        b.feed(inst.inputs["Rotation"], _euler_from_quaternion(b, b.named("rotation", "FLOAT_COLOR")))
    b.feed(inst.inputs["Scale"], b.vmath("SCALE", b.named("scale", "FLOAT_VECTOR"), scale=size))
    # The points themselves stay in the output (loose vertices draw nothing in Object Mode): without
    # them the object's bounds, and so its Dimensions, would be zero (instances do not count).
    # The display value is computed on the instances (their attributes come from the points they
    # stand on), so a material edit of 1M splats evaluates the field on the shown subset only and
    # leaves the points unchanged: no copy of the splat mesh (measured on 1M splats, 20,000 shown:
    # re-evaluation after an albedo edit 0.49 s -> see README, live viewport).
    store = b.node("GeometryNodeStoreNamedAttribute", data_type="FLOAT_VECTOR", domain="INSTANCE")
    b.feed(store.inputs["Geometry"], inst.outputs[0])
    store.inputs["Name"].default_value = DISPLAY_ATTRIBUTE
    b.feed(_enabled(store.inputs, "Value"), total)
    join = b.node("GeometryNodeJoinGeometry")
    b.feed(join.inputs[0], store.outputs[0])
    b.feed(join.inputs[0], geometry)
    b.feed(gout.inputs[0], join.outputs[0])
    return group


def upgrade_display():
    """Rebuilds a display group saved by an older version of the add-on (files open with the group they were
    saved with), keeping each display modifier's settings; returns the number of objects updated."""
    group = bpy.data.node_groups.get(DISPLAY_GROUP)
    if group is None or group.get("ptir_version") == DISPLAY_GROUP_VERSION:
        return 0
    users = []
    for obj in bpy.data.objects:
        mod = obj.modifiers.get(DISPLAY_MODIFIER) if obj.type == "MESH" else None
        if mod is not None and mod.node_group == group:
            values = {}
            for name in ("Fraction", "Size", "Mode", "Material"):
                try:
                    values[name] = mod[_modifier_input(mod, name)]
                except KeyError:
                    pass
            users.append((obj, mod, values))
    display_group()
    for obj, mod, values in users:
        for name, value in values.items():
            mod[_modifier_input(mod, name)] = value
        obj.data.update()
    return len(users)


def display_material():
    mat = bpy.data.materials.get(DISPLAY_MATERIAL)
    if mat is not None and mat.get("ptir_version") == 1:
        return mat
    if mat is None:
        mat = bpy.data.materials.new(DISPLAY_MATERIAL)
    mat["ptir_version"] = 1
    compat.ensure_nodes(mat)
    mat.diffuse_color = (0.7, 0.7, 0.7, 1.0)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    attr = nodes.new("ShaderNodeAttribute")
    attr.attribute_type = "INSTANCER"
    attr.attribute_name = DISPLAY_ATTRIBUTE
    attr.location = (-400, 0)
    emit = nodes.new("ShaderNodeEmission")
    emit.location = (-150, 0)
    out = nodes.new("ShaderNodeOutputMaterial")
    out.location = (100, 0)
    links.new(attr.outputs["Vector"], emit.inputs["Color"])
    links.new(emit.outputs[0], out.inputs["Surface"])
    return mat


def _modifier_input(mod, name):
    for item in _group_inputs(mod.node_group):
        if item.name == name:
            return item.identifier
    raise KeyError(name)


def set_display_input(obj, name, value):
    mod = obj.modifiers.get(DISPLAY_MODIFIER)
    if mod is None or mod.node_group is None:
        return False
    mod[_modifier_input(mod, name)] = value
    obj.data.update()  # re-evaluate the modifier
    return True


def add_display(obj, limit=DEFAULT_DISPLAY_LIMIT, size=DEFAULT_DISPLAY_SIZE, mode="COLOR"):
    """Adds (or refreshes) the display modifier: at most `limit` splats shown as ellipsoids."""
    mod = obj.modifiers.get(DISPLAY_MODIFIER)
    if mod is None:
        mod = obj.modifiers.new(DISPLAY_MODIFIER, "NODES")
    mod.node_group = display_group()
    n = max(1, len(obj.data.vertices))
    mod[_modifier_input(mod, "Fraction")] = float(min(1.0, limit / n)) if limit > 0 else 1.0
    mod[_modifier_input(mod, "Size")] = float(size)
    mod[_modifier_input(mod, "Mode")] = DISPLAY_MODES.index(mode)
    mod[_modifier_input(mod, "Material")] = display_material()
    obj.data.update()
    return mod


def remove_display(obj):
    mod = obj.modifiers.get(DISPLAY_MODIFIER)
    if mod is not None:
        obj.modifiers.remove(mod)


def splat_objects(scene, view_layer=None, visible_only=True):
    for obj in scene.objects:
        if not is_splat_object(obj):
            continue
        if visible_only and obj.hide_render:
            continue
        if view_layer is not None and obj.name not in view_layer.objects:
            continue
        yield obj


def selection_mask(obj, vertex_group=""):
    """Boolean (n,) mask of the splats to edit: a vertex group's members when named, else the edit-mode
    selection in edit mode, else every splat. Raises SplatObjectError when the group is missing.

    Vertex-group membership has no bulk accessor in Blender's API; it is read by letting Blender select
    the group's vertices (object.vertex_group_select, C code) and reading the selection flags with
    foreach_get; the original selection and mode are restored.
    """
    mesh = obj.data
    n = len(mesh.vertices)
    if vertex_group:
        vg = obj.vertex_groups.get(vertex_group)
        if vg is None:
            raise SplatObjectError("object '%s' has no vertex group '%s'" % (obj.name, vertex_group))
        return _vertex_group_mask(obj, vg)
    if obj.mode == "EDIT":
        obj.update_from_editmode()
        sel = np.zeros(n, bool)
        mesh.vertices.foreach_get("select", sel)
        return sel
    return np.ones(n, bool)


def _vertex_group_mask(obj, vg):
    mesh = obj.data
    n = len(mesh.vertices)
    was_edit = obj.mode == "EDIT"
    if was_edit:
        obj.update_from_editmode()
    saved = np.zeros(n, bool)
    mesh.vertices.foreach_get("select", saved)
    view_layer = bpy.context.view_layer
    previous_active = view_layer.objects.active
    previous_group = obj.vertex_groups.active_index
    view_layer.objects.active = obj
    try:
        if not was_edit:
            bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="DESELECT")
        obj.vertex_groups.active_index = vg.index
        bpy.ops.object.vertex_group_select()
        bpy.ops.object.mode_set(mode="OBJECT")
        mask = np.zeros(n, bool)
        mesh.vertices.foreach_get("select", mask)
        mesh.vertices.foreach_set("select", saved)
        mesh.update()
    finally:
        obj.vertex_groups.active_index = previous_group
        if was_edit and obj.mode != "EDIT":
            bpy.ops.object.mode_set(mode="EDIT")
        elif not was_edit and obj.mode != "OBJECT":
            bpy.ops.object.mode_set(mode="OBJECT")
        view_layer.objects.active = previous_active
    return mask
