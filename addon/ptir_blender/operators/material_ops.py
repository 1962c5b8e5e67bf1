"""Editing the recovered materials of splats: set / tint / scale albedo, roughness, metallic.

    bpy.ops.ptir.edit_material(channel='ALBEDO', operation='TINT', color=(1, 0.5, 0.5))
    bpy.ops.ptir.edit_material(channel='ROUGHNESS', operation='SET', value=0.2, vertex_group="hood")

Acts on the active splat object: the splats of `vertex_group` when given, else
the edit-mode selection in edit mode, else all of them. One bulk numpy update of
the point attributes (ptir_albedo / ptir_roughness / ptir_metallic), undoable.
The live viewport's engine gets the edit at once, before Blender's own update:
only the edited channel of the edited splats (engine_sync.push_material_edit),
and its first pass starts while Blender updates (viewport_render.kick_all).
"""

import bpy
import numpy as np
from bpy.props import EnumProperty, FloatProperty, FloatVectorProperty, StringProperty

from ..blender import engine_sync, splat_display, splat_object, viewport_render
from ..errors import PtirError


class MaterialEdit:
    """What an edit changed: the engine's channel name, the edited splats (None: all of them) and their new
    values ((m, 3) albedo or (m,)); the live viewport sends exactly this (engine_sync.push_material_edit)."""

    def __init__(self, channel, indices, values):
        self.channel, self.indices, self.values = channel, indices, values
        self.needs_update = True

    def __len__(self):
        return len(self.values)


def edit_material(obj, channel, operation, color=(1.0, 1.0, 1.0), value=1.0, mask=None, defer_update=False):
    """Applies the edit to obj's splats in `mask` (all when None); returns a MaterialEdit (empty when no
    splat is selected). Only the edited channel is read and written. defer_update: leave out the mesh's
    depsgraph update when Blender shows nothing of the change (then the MaterialEdit's needs_update is
    False and the caller updates the mesh if anything else must see it).

    The object must be in object mode (its mesh data is written).
    """
    mesh = obj.data
    n = len(mesh.vertices)
    sel = np.ones(n, bool) if mask is None else np.asarray(mask, bool)
    indices = None if sel.all() else np.flatnonzero(sel).astype(np.uint32)
    name = {"ALBEDO": "albedo", "ROUGHNESS": "roughness", "METALLIC": "metallic"}.get(channel)
    if name is None:
        raise ValueError("unknown channel %r" % channel)
    if not sel.any():
        return MaterialEdit(name, indices, np.zeros(0, np.float32))
    v = splat_object.read_material_channel(mesh, name, "object '%s'" % obj.name)
    part = v if indices is None else v[indices]
    if operation == "SET":
        part = np.broadcast_to(np.asarray(color, np.float32)[:3] if name == "albedo" else np.float32(value),
                               part.shape)
    elif operation == "TINT" and name == "albedo":
        part = part * np.asarray(color, np.float32)[:3]
    elif operation in ("SCALE", "TINT"):
        part = part * np.float32(value)
    else:
        raise ValueError("unknown operation %r" % operation)
    part = np.clip(part, 0.0, 1.0).astype(np.float32)
    if indices is None:
        v = part
    else:
        v[indices] = part
    attr_name = splat_object.MATERIAL_CHANNELS[name][0]
    in_place = _writes_in_place(mesh, attr_name)
    splat_object.write_material_attributes(mesh, **{name: v})
    done = MaterialEdit(name, indices, part)
    done.needs_update = not in_place or _displayed(obj, name)
    if done.needs_update or not defer_update:
        mesh.update()
    # Otherwise (defer_update) the caller decides: the values were written into the existing attribute,
    # which the evaluated mesh references, and nothing Blender draws shows them (the display modifier
    # shows another channel), so only the live viewport needs to know, and the operator tells it
    # directly (engine_sync.push_material_edit). Re-evaluating a 1M-splat object costs 0.25-0.45 s
    # (its copy-on-write copy and the display modifier): most of an edit's latency in the viewport.
    # Undo stores the data itself.
    return done


def _writes_in_place(mesh, attr_name):
    a = mesh.attributes.get(attr_name)
    return a is not None and a.domain == "POINT" and a.data_type == ("FLOAT_COLOR" if attr_name == "ptir_albedo"
                                                                       else "FLOAT")


def _displayed(obj, channel):
    """Whether the viewport display of obj shows this material channel."""
    mod = obj.modifiers.get(splat_display.DISPLAY_MODIFIER)
    settings = getattr(obj, "ptir_splat", None)
    return mod is not None and mod.show_viewport and settings is not None and settings.display == channel.upper()


class PTIR_OT_edit_material(bpy.types.Operator):
    """Set, tint or scale the albedo, roughness or metallic of the selected splats"""
    bl_idname = "ptir.edit_material"
    bl_label = "Apply Material Edit"
    bl_options = {"REGISTER", "UNDO"}

    channel: EnumProperty(name="Channel", items=[("ALBEDO", "Albedo", ""), ("ROUGHNESS", "Roughness", ""),
                                                 ("METALLIC", "Metallic", "")], default="ALBEDO")
    operation: EnumProperty(name="Operation", items=[("SET", "Set", "Replace the value"),
                                                     ("TINT", "Tint", "Multiply by the colour (albedo)"),
                                                     ("SCALE", "Scale", "Multiply by the value")],
                            default="SET")
    color: FloatVectorProperty(name="Colour", subtype="COLOR", size=3, default=(0.8, 0.8, 0.8), min=0.0)
    value: FloatProperty(name="Value", default=0.5, min=0.0)
    vertex_group: StringProperty(name="Vertex Group", default="")

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if splat_object.is_splat_object(obj):
            return True
        if hasattr(cls, "poll_message_set"):
            cls.poll_message_set("The active object is not a splat object")
        return False

    def execute(self, context):
        obj = context.active_object
        if self.channel != "ALBEDO" and self.operation == "TINT":
            self.report({"ERROR"}, "Tint applies to the albedo; use Scale for %s" % self.channel.lower())
            return {"CANCELLED"}
        try:
            mask = splat_object.selection_mask(obj, self.vertex_group)
        except PtirError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        if not mask.any():
            self.report({"WARNING"}, "No splats selected (select some in edit mode, or name a vertex group)")
            return {"CANCELLED"}
        was_edit = obj.mode == "EDIT"
        if was_edit:
            bpy.ops.object.mode_set(mode="OBJECT")
        try:
            done = edit_material(obj, self.channel, self.operation, self.color, self.value, mask,
                                 defer_update=not was_edit)
        except PtirError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        finally:
            if was_edit:
                bpy.ops.object.mode_set(mode="EDIT")
        if not was_edit:  # (leaving edit mode may also have written moved vertices)
            # Every object showing this mesh (linked duplicates share its attributes) gets the edit.
            users = [o for o in context.scene.objects if o.data is obj.data]
            pushed = [engine_sync.session().push_material_edit(o.name, done, update_follows=done.needs_update)
                      for o in users]
            if any(pushed):
                viewport_render.kick_all()
            if not all(pushed) and not done.needs_update:
                obj.data.update()  # a live viewport did not take it: the depsgraph update tells the engine
        self.report({"INFO"}, "%s of %d splats: %s" % (self.channel.capitalize(), len(done), self.operation.lower()))
        return {"FINISHED"}


classes = (PTIR_OT_edit_material,)
