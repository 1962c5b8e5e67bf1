"""Editing the recovered materials of splats: set / tint / scale albedo, roughness, metallic.

    bpy.ops.ptir.edit_material(channel='ALBEDO', operation='TINT', color=(1, 0.5, 0.5))
    bpy.ops.ptir.edit_material(channel='ROUGHNESS', operation='SET', value=0.2, vertex_group="hood")

Acts on the active splat object: the splats of `vertex_group` when given, else
the edit-mode selection in edit mode, else all of them. One bulk numpy update of
the point attributes (ptir_albedo / ptir_roughness / ptir_metallic), undoable.
The render engine exports the attributes on every render, so the next render
shows the change, with its effect on indirect light.
"""

import bpy
import numpy as np
from bpy.props import EnumProperty, FloatProperty, FloatVectorProperty, StringProperty

from ..blender import engine_sync, splat_object
from ..errors import PtirError


def edit_material(obj, channel, operation, color=(1.0, 1.0, 1.0), value=1.0, mask=None):
    """Applies the edit to obj's splats in `mask` (all when None); returns how many splats changed.

    The object must be in object mode (its mesh data is written).
    """
    mesh = obj.data
    n = len(mesh.vertices)
    sel = np.ones(n, bool) if mask is None else np.asarray(mask, bool)
    count = int(sel.sum())
    if count == 0:
        return 0
    albedo, roughness, metallic = splat_object.read_material_attributes(mesh, "object '%s'" % obj.name)
    if channel == "ALBEDO":
        c = np.asarray(color, np.float32)[:3]
        a = albedo.copy()
        if operation == "SET":
            a[sel] = c
        elif operation == "TINT":
            a[sel] *= c
        elif operation == "SCALE":
            a[sel] *= np.float32(value)
        else:
            raise ValueError("unknown operation %r" % operation)
        splat_object.write_material_attributes(mesh, albedo=np.clip(a, 0.0, 1.0))
    elif channel in ("ROUGHNESS", "METALLIC"):
        v = (roughness if channel == "ROUGHNESS" else metallic).copy()
        if operation == "SET":
            v[sel] = np.float32(value)
        elif operation in ("SCALE", "TINT"):
            v[sel] *= np.float32(value)
        else:
            raise ValueError("unknown operation %r" % operation)
        v = np.clip(v, 0.0, 1.0)
        if channel == "ROUGHNESS":
            splat_object.write_material_attributes(mesh, roughness=v)
        else:
            splat_object.write_material_attributes(mesh, metallic=v)
    else:
        raise ValueError("unknown channel %r" % channel)
    mesh.update()
    return count


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
            count = edit_material(obj, self.channel, self.operation, self.color, self.value, mask)
        except PtirError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        finally:
            if was_edit:
                bpy.ops.object.mode_set(mode="EDIT")
        if not was_edit:  # (leaving edit mode may also have written moved vertices)
            engine_sync.session().note_material_edit(obj.name)
        self.report({"INFO"}, "%s of %d splats: %s" % (self.channel.capitalize(), count, self.operation.lower()))
        return {"FINISHED"}


classes = (PTIR_OT_edit_material,)
