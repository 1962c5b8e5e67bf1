"""Material editing on splats (bpy.ops.ptir.edit_material) in blender -b (run by test_addon_edit.py).

    blender -b ... -P addon_edit_check.py -- PLY

Checks set / tint / scale of albedo, roughness and metallic on: all splats (object mode), a vertex
group's splats, the edit-mode selection; that only the targeted splats change (values clamped to
[0, 1]), that mode, selection and the other attributes are kept, and the errors (unknown group, tint
on a scalar, no selection). Undo is checked in a real window (addon_ui_shot.py).
"""

import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402

h.enable_addon()
from ptir_blender.blender import splat_object  # noqa: E402


def material(obj):
    return splat_object.read_material_attributes(obj.data)


def edit(**kw):
    try:
        return bpy.ops.ptir.edit_material(**kw), ""
    except RuntimeError as e:
        return {"CANCELLED"}, str(e)


def main():
    ply = h.argv()[0]
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    h.check(bpy.ops.import_scene.gaussian_splat_ply(filepath=ply) == {"FINISHED"}, "import")
    obj = bpy.context.active_object
    n = len(obj.data.vertices)
    other = splat_object.read_data_from_object(obj)

    # All splats, object mode.
    r, _ = edit(channel="ALBEDO", operation="SET", color=(0.2, 0.4, 0.6))
    h.check(r == {"FINISHED"}, "set albedo")
    a, rough, metal = material(obj)
    h.check(np.allclose(a, (0.2, 0.4, 0.6)), "albedo set on every splat")
    r, _ = edit(channel="ALBEDO", operation="TINT", color=(0.5, 1.0, 2.0))
    a, _, _ = material(obj)
    h.check(np.allclose(a, (0.1, 0.4, 1.0)), "tint multiplies and clamps to 1: %s" % a[0])

    # A vertex group.
    vg = obj.vertex_groups.new(name="hood")
    members = list(range(0, n, 7))
    vg.add(members, 1.0, "REPLACE")
    obj.data.vertices.foreach_set("select", np.zeros(n, bool))
    r, _ = edit(channel="ROUGHNESS", operation="SET", value=0.15, vertex_group="hood")
    h.check(r == {"FINISHED"}, "set roughness on a group")
    _, rough2, _ = material(obj)
    mask = np.zeros(n, bool)
    mask[members] = True
    h.check(np.allclose(rough2[mask], 0.15) and np.array_equal(rough2[~mask], rough[~mask]),
            "only the group's splats changed")
    sel = np.empty(n, bool)
    obj.data.vertices.foreach_get("select", sel)
    h.check(not sel.any() and obj.mode == "OBJECT", "selection and mode kept")
    r, _ = edit(channel="ROUGHNESS", operation="SCALE", value=3.0, vertex_group="hood")
    _, rough3, _ = material(obj)
    h.check(np.allclose(rough3[mask], 0.45) and np.array_equal(rough3[~mask], rough[~mask]), "scale")

    # The edit-mode selection.
    chosen = np.zeros(n, bool)
    chosen[5:25] = True
    obj.data.vertices.foreach_set("select", chosen)
    bpy.ops.object.mode_set(mode="EDIT")
    r, _ = edit(channel="METALLIC", operation="SET", value=0.9)
    h.check(r == {"FINISHED"} and obj.mode == "EDIT", "metallic set in edit mode, still in edit mode")
    bpy.ops.object.mode_set(mode="OBJECT")
    _, _, metal2 = material(obj)
    h.check(np.allclose(metal2[chosen], 0.9) and np.array_equal(metal2[~chosen], metal[~chosen]),
            "only the selected splats changed")
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="DESELECT")
    r, msg = edit(channel="METALLIC", operation="SET", value=0.5)
    h.check(r == {"CANCELLED"}, "nothing selected: nothing to do")
    bpy.ops.object.mode_set(mode="OBJECT")

    # Errors.
    r, msg = edit(channel="ALBEDO", operation="SET", vertex_group="nope")
    h.check(r == {"CANCELLED"} and "no vertex group 'nope'" in msg, msg)
    r, msg = edit(channel="ROUGHNESS", operation="TINT")
    h.check(r == {"CANCELLED"} and "Tint" in msg, msg)

    # Geometry and radiance untouched.
    after = splat_object.read_data_from_object(obj)
    for f in ("position", "scale", "rotation", "opacity", "f_dc", "normal"):
        h.check(np.array_equal(getattr(after, f), getattr(other, f)), "%s untouched" % f)
    print("edit: set/tint/scale on all, group (%d) and selection (%d) splats" % (len(members), chosen.sum()))


h.run(main)
