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

The viewport display of these objects (a Geometry Nodes modifier) is splat_display.py.
"""

import bpy
import numpy as np

from . import splat_display
from ..io import splat_ply, splat_transform
from ..io.splat_ply import SplatData
from ..errors import SplatObjectError

REQUIRED_ATTRIBUTES = ("scale", "rotation", "opacity")

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


def create_splat_object(context, d, name, collection=None, display_limit=splat_display.DEFAULT_DISPLAY_LIMIT,
                        display_size=splat_display.DEFAULT_DISPLAY_SIZE, display=True):
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
        splat_display.add_display(obj, display_limit, display_size)
    return obj


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
