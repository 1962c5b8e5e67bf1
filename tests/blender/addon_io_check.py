"""Import / export operators inside Blender (run by test_addon_io.py).

    blender -b --factory-startup -noaudio --python-exit-code 1 -P addon_io_check.py -- TMPDIR

Checks, on PLYs written here with known raw values:
  1. import: every point attribute equals the PLY's activated values (position, scale, rotation,
     opacity, SH DC and rest, albedo, roughness, metallic, normal), also against the engine's loader
  2. export -> re-import: every attribute equal, bit for bit; the file is the standard layout
  3. export folds the object transform (positions, scales, rotations, normals)
  4. malformed PLYs: the operator fails with a message naming the problem and the scene is unchanged
  5. the viewport display: a Geometry Nodes modifier instancing at most the display limit, switchable
"""

import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402
import addon_common as ac  # noqa: E402

h.enable_addon()
from ptir_blender.blender import splat_display, splat_object  # noqa: E402
from ptir_blender.io import splat_ply, splat_transform  # noqa: E402

ATTRS = ("scale", "rotation", "opacity", "radiance:base", "ptir_albedo", "ptir_roughness", "ptir_metallic",
         "ptir_normal")


def scene_state():
    return (sorted(o.name for o in bpy.data.objects), sorted(m.name for m in bpy.data.meshes),
            sorted(m.name for m in bpy.data.materials), sorted(g.name for g in bpy.data.node_groups))


def import_ply(path):
    before = set(bpy.data.objects)
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=str(path))
    h.check(r == {"FINISHED"}, "import returned %s" % r)
    new = [o for o in bpy.data.objects if o not in before]
    h.check(len(new) == 1, "expected one new object, got %d" % len(new))
    return new[0]


def assert_equal(a, b, what):
    a, b = np.asarray(a), np.asarray(b)
    h.check(a.shape == b.shape, "%s: shapes %s vs %s" % (what, a.shape, b.shape))
    bad = int(np.sum(a != b))
    h.check(bad == 0, "%s: %d values differ (max |diff| %g)" % (what, bad, float(np.max(np.abs(a - b)))))


def check_import(tmp):
    raw = ac.random_raw(3000, material=True, seed=11)
    raw["confidence"] = np.linspace(0.0, 1.0, 3000)
    path = ac.write_ply(os.path.join(tmp, "capture.ply"), raw)
    obj = import_ply(path)
    h.check(obj.type == "MESH" and len(obj.data.vertices) == 3000, "vertex-only mesh with 3000 points")
    h.check(len(obj.data.edges) == 0 and len(obj.data.polygons) == 0, "no edges or faces")
    h.check(obj.name == "capture", "object named after the file, got %s" % obj.name)
    for a in ATTRS + tuple("radiance:sh_%d" % k for k in range(15)) + ("ply:confidence",):
        attr = obj.data.attributes.get(a)
        h.check(attr is not None and attr.domain == "POINT", "point attribute %s" % a)
    rot = obj.data.attributes["rotation"]
    h.check(rot.data_type == ("QUATERNION" if bpy.app.version >= (4, 0, 0) else "FLOAT_COLOR"),
            "rotation stored as a 4-float attribute (%s)" % rot.data_type)
    h.check(obj.data.attributes["ptir_albedo"].data_type == "FLOAT_COLOR", "albedo is a colour attribute")

    got = splat_object.read_data_from_object(obj)
    ref = ac.activated_reference(raw)
    for f in ("position", "scale", "rotation", "opacity"):
        assert_equal(getattr(got, f), ref[f], "import %s vs activated reference" % f)
    assert_equal(got.f_dc, np.stack([np.float32(raw["f_dc_%d" % k]) for k in range(3)], 1), "radiance:base")
    for k in range(15):
        want = np.stack([np.float32(raw["f_rest_%d" % (c * 15 + k)]) for c in range(3)], 1)
        assert_equal(got.sh_rest[k], want, "radiance:sh_%d" % k)
    assert_equal(got.albedo, np.stack([np.float32(raw["albedo_%d" % k]) for k in range(3)], 1), "ptir_albedo")
    assert_equal(got.roughness, np.float32(raw["roughness"]), "ptir_roughness")
    assert_equal(got.metallic, np.float32(raw["metallic"]), "ptir_metallic")
    nrm = np.stack([raw[c] for c in ("nx", "ny", "nz")], 1).astype(np.float32).astype(np.float64)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    h.check(np.max(np.abs(got.normal - nrm)) < 3e-7, "ptir_normal = normalised nx, ny, nz")
    assert_equal(got.extra["confidence"], np.float32(raw["confidence"]), "ply:confidence")
    # the raw attribute arrays themselves (not through the add-on's reader)
    sc = np.empty(3000 * 3, np.float32)
    obj.data.attributes["scale"].data.foreach_get("vector", sc)
    assert_equal(sc.reshape(-1, 3), ref["scale"], "scale attribute")
    ptir = h.native_module()
    if ptir is not None:
        g = ptir.load_gaussians(str(path))
        assert_equal(got.position, g.position, "position vs engine")
        h.check(ac.ulps(got.scale, g.scale).max() <= 1, "scale within 1 ulp of the engine")
        h.check(ac.ulps(got.opacity, g.opacity).max() <= 2, "opacity within 2 ulps of the engine")
        assert_equal(got.albedo, g.albedo, "albedo vs engine")
        print("import: equal to the engine's loader (scale/opacity within 1/2 ulp of its expf)")
    return obj, path


def check_round_trip(tmp, obj):
    out = os.path.join(tmp, "exported.ply")
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    r = bpy.ops.export_scene.gaussian_splat_ply(filepath=out)
    h.check(r == {"FINISHED"}, "export returned %s" % r)
    props = [p[0] for p in splat_ply.read_ply_elements(out)["__elements__"][0].props]
    h.check(props[:9] == ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"], "standard layout")
    h.check(props[-6:] == ["albedo_0", "albedo_1", "albedo_2", "roughness", "metallic", "confidence"],
            "material properties after the standard ones: %s" % props[-6:])
    again = import_ply(out)
    a = splat_object.read_data_from_object(obj)
    b = splat_object.read_data_from_object(again)
    for f in splat_ply.SplatData.FIELDS:
        assert_equal(getattr(b, f), getattr(a, f), "round trip %s" % f)
    for name in obj.data.attributes.keys():
        if name.startswith("."):
            continue
        attr = obj.data.attributes[name]
        w = {"FLOAT": 1, "FLOAT_VECTOR": 3, "FLOAT_COLOR": 4, "QUATERNION": 4}[attr.data_type]
        key = {"FLOAT": "value", "FLOAT_VECTOR": "vector", "FLOAT_COLOR": "color", "QUATERNION": "value"}
        x = np.empty(len(obj.data.vertices) * w, np.float32)
        y = np.empty_like(x)
        attr.data.foreach_get(key[attr.data_type], x)
        again.data.attributes[name].data.foreach_get(key[attr.data_type], y)
        assert_equal(y, x, "round trip attribute %s" % name)
    bpy.data.objects.remove(again)
    print("round trip: %d attributes bit-identical" % len([k for k in obj.data.attributes.keys()
                                                          if not k.startswith(".")]))


def check_transform(tmp, obj):
    obj.location = (1.0, -2.0, 0.5)
    obj.rotation_euler = (0.3, -0.2, 1.1)
    obj.scale = (2.0, 2.0, 2.0)
    bpy.context.view_layer.update()
    out = os.path.join(tmp, "moved.ply")
    h.check(bpy.ops.export_scene.gaussian_splat_ply(filepath=out) == {"FINISHED"}, "export moved")
    d = splat_ply.read_splat_ply(out)
    local = splat_object.read_data_from_object(obj)
    m = np.array(obj.matrix_world, np.float64)
    want = local.position.astype(np.float64) @ m[:3, :3].T + m[:3, 3]
    h.check(np.max(np.abs(d.position - want)) < 1e-5, "positions moved by the object transform")
    h.check(np.max(np.abs(d.scale / local.scale - 2.0)) < 1e-5, "scales times the object scale")
    r = m[:3, :3] / 2.0
    rl = splat_transform.quat_to_matrix(local.rotation)
    rw = splat_transform.quat_to_matrix(d.rotation)
    h.check(np.max(np.abs(np.einsum("ij,njk->nik", r, rl) - rw)) < 1e-5, "rotations composed with the object's")
    h.check(np.max(np.abs(d.normal - local.normal @ r.T)) < 1e-5, "normals rotated")
    np.testing.assert_array_equal(d.albedo, local.albedo)
    # Apply Transform off: local values
    out2 = os.path.join(tmp, "local.ply")
    bpy.ops.export_scene.gaussian_splat_ply(filepath=out2, apply_transform=False)
    np.testing.assert_array_equal(splat_ply.read_splat_ply(out2).position, local.position)
    obj.location, obj.rotation_euler, obj.scale = (0, 0, 0), (0, 0, 0), (1, 1, 1)
    print("export: object transform folded into positions, scales, rotations and normals")


def check_malformed(tmp):
    raw = ac.random_raw(50, sh_rest=0, seed=12)
    cases = {
        "mesh.ply": ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                     "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                     "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "missing properties scale_0, scale_1, scale_2, rot_0"),
        "no_rot.ply": (None, "missing properties rot_3"),
        "sh.ply": (None, "unsupported SH: 5 f_rest_* properties"),
        "garbage.ply": ("this is not a ply\n", "not a PLY file"),
    }
    ac.write_ply(os.path.join(tmp, "no_rot.ply"), {k: v for k, v in raw.items() if k != "rot_3"})
    ac.write_ply(os.path.join(tmp, "sh.ply"), dict(raw, **{"f_rest_%d" % i: np.zeros(50) for i in range(5)}))
    for name, (text, expected) in cases.items():
        path = os.path.join(tmp, name)
        if text is not None:
            with open(path, "w") as f:
                f.write(text)
        before = scene_state()
        try:
            r = bpy.ops.import_scene.gaussian_splat_ply(filepath=path)
        except RuntimeError as e:  # an ERROR report raises in scripts
            msg = str(e)
        else:
            raise AssertionError("%s: import did not fail (%s)" % (name, r))
        h.check(expected in msg and path in msg, "%s: message '%s' lacks '%s'" % (name, msg, expected))
        h.check(scene_state() == before, "%s: the scene changed" % name)
        print("malformed %s -> %s" % (name, msg.strip().splitlines()[-1]))
    # export of a non-splat object fails cleanly too
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.active_object
    before = scene_state()
    try:
        bpy.ops.export_scene.gaussian_splat_ply(filepath=os.path.join(tmp, "x.ply"), use_selection=True)
        raise AssertionError("exporting a cube did not fail")
    except RuntimeError as e:
        h.check("splat" in str(e), str(e))
    h.check(not os.path.exists(os.path.join(tmp, "x.ply")) and scene_state() == before, "nothing written")
    bpy.data.objects.remove(cube)


def check_display(obj):
    mod = obj.modifiers.get(splat_display.DISPLAY_MODIFIER)
    h.check(mod is not None and mod.type == "NODES", "display modifier")
    dg = bpy.context.evaluated_depsgraph_get()
    count = sum(1 for i in dg.object_instances if i.is_instance and i.parent and i.parent.original == obj)
    h.check(count == len(obj.data.vertices), "all %d splats instanced (got %d)" % (len(obj.data.vertices), count))
    obj.ptir_splat.display_limit = 1000
    dg = bpy.context.evaluated_depsgraph_get()
    dg.update()
    count = sum(1 for i in dg.object_instances if i.is_instance and i.parent and i.parent.original == obj)
    h.check(600 < count < 1400, "display limit 1000 of 3000 shows about 1000 (got %d)" % count)
    obj.ptir_splat.display = "ALBEDO"
    ident = next(i.identifier for i in splat_display._group_inputs(mod.node_group) if i.name == "Mode")
    h.check(mod[ident] == 1, "display mode albedo sets the modifier input")
    obj.ptir_splat.display = "COLOR"
    obj.ptir_splat.display_limit = splat_display.DEFAULT_DISPLAY_LIMIT
    print("display: %d instances with limit 1000" % count)


def engine_available():
    render = bpy.context.scene.render
    old = render.engine
    try:
        render.engine = "PTIR"
    except TypeError:
        return False
    render.engine = old
    return True


def check_register_cycle():
    """Disabling removes every class, menu entry, pointer property and panel engine tag; enabling again
    restores them (register/unregister are symmetric)."""
    import addon_utils
    addon_utils.disable("ptir_blender", default_set=True)
    h.check(not hasattr(bpy.types.Scene, "ptir_render") and not hasattr(bpy.types.Object, "ptir_splat"),
            "pointer properties removed")
    h.check(getattr(bpy.types, "PTIR_OT_optimize", None) is None
            and getattr(bpy.types, "IMPORT_SCENE_OT_gaussian_splat_ply", None) is None, "operators unregistered")
    h.check(all("PTIR" not in (getattr(getattr(bpy.types, n), "COMPAT_ENGINES", None) or ())
                for n in dir(bpy.types)), "panel engine tags removed")
    h.check(not engine_available(), "render engine unregistered")
    h.enable_addon()
    h.check(hasattr(bpy.types.Scene, "ptir_render") and getattr(bpy.types, "PTIR_OT_optimize", None) is not None
            and engine_available(), "registered again")
    print("register/unregister: symmetric")


def check_other_layouts(tmp):
    """SH degree 4 (72 f_rest: Blender 5.3's splats carry up to degree 4) imports into radiance:sh_0..23
    and exports back bit for bit; a 2DGS file (no scale_2) imports as flat splats."""
    raw = ac.random_raw(200, sh_rest=72, seed=13)
    obj = import_ply(ac.write_ply(os.path.join(tmp, "sh4.ply"), raw))
    h.check(obj.data.attributes.get("radiance:sh_23") is not None, "degree 4: radiance:sh_23")
    got = splat_object.read_data_from_object(obj)
    for k in (0, 15, 23):
        want = np.stack([np.float32(raw["f_rest_%d" % (c * 24 + k)]) for c in range(3)], 1)
        assert_equal(got.sh_rest[k], want, "degree 4 radiance:sh_%d" % k)
    out = os.path.join(tmp, "sh4_out.ply")
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    h.check(bpy.ops.export_scene.gaussian_splat_ply(filepath=out) == {"FINISHED"}, "degree 4 export")
    assert_equal(splat_ply.read_splat_ply(out).sh_rest, got.sh_rest, "degree 4 round trip")
    bpy.data.objects.remove(obj)
    raw = ac.random_raw(200, sh_rest=0, normals=False, seed=14)
    del raw["scale_2"]
    obj = import_ply(ac.write_ply(os.path.join(tmp, "surfels.ply"), raw))
    got = splat_object.read_data_from_object(obj)
    h.check(np.all(got.scale[:, 2] < got.scale[:, :2].min(axis=1)), "2DGS: the third scale is the thinnest")
    bpy.data.objects.remove(obj)
    print("other layouts: SH degree 4 round trip, 2DGS surfels")


def main():
    tmp = h.argv()[0]
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    obj, _ = check_import(tmp)
    check_display(obj)
    check_round_trip(tmp, obj)
    check_transform(tmp, obj)
    check_malformed(tmp)
    check_other_layouts(tmp)
    check_register_cycle()


h.run(main)
