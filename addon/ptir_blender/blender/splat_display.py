"""The viewport display of splat objects: a Geometry Nodes modifier ("PTIR Splat Display") that
instances a low-poly ellipsoid per splat (scaled by its standard deviations, rotated by its
quaternion), showing at most a capped number of splats, coloured by the SH colour, the albedo,
the roughness, the metallic or the normal (the object's ptir_splat.display setting) through the
material "PTIR Splat Display". The attributes it reads are splat_object.py's.
"""

import bpy

from . import compat
from ..io import splat_ply

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
