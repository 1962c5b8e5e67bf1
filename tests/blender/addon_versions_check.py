"""The add-on in the Blender it runs in (3.4, bpy 4.5, bpy 5.0; run by test_addon_versions.py).

    <blender> ... addon_versions_check.py -- TMPDIR        (blenders.py: how each Blender runs it)

Checks, each printed, in this Blender:
  1. no deprecation warning: Python's warnings (Blender's RNA deprecations among them, e.g. 5.0's
     Material/World/Scene.use_nodes) are recorded, always, from enabling the add-on to disabling it,
     through importing splats, exporting a scene with a Principled material, the world and a light,
     writing materials back, and the PTIR engine chosen; none may come from the repository's files
  2. panels where Cycles' are: each EEVEE panel standing in for Cycles' own (material slots and surface,
     world surface, light) exists under the same name and shows under PTIR; Blender's panels that Cycles
     shows (camera, lens, format, output, colour management, ...) show; no EEVEE-only panel (shadows,
     light probes, blend modes) and no Cycles panel shows; disabling restores every panel's
     COMPAT_ENGINES (the same set object, the same engines)
  3. the engines: EEVEE's name of this version (BLENDER_EEVEE_NEXT in 4.2-4.5, else BLENDER_EEVEE) and
     PTIR can be set as the scene's engine
  4. write-back: the Principled BSDF inputs of this Blender's model (v1: Specular, Specular Tint float;
     v2: IOR, Specular IOR Level, Specular Tint colour, Diffuse Roughness from 4.3) set by name, read back
     by the exporter as the same engine material; a material without a Principled gets one, linked
  5. the splat object keeps Blender 5.3's native attribute names (position, scale, rotation,
     radiance:base, radiance:sh_<k>)
Prints "VERSIONS_STATS: {...}".
"""

import json
import os
import sys
import warnings

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402
import addon_common as ac  # noqa: E402

REPO_FILES = (os.path.join(h.REPO, "addon"), os.path.join(h.REPO, "scripts"))
COUNTERPARTS = ("EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface", "EEVEE_WORLD_PT_surface",
                "DATA_PT_EEVEE_light")
CYCLES_BUILTINS = ("DATA_PT_camera", "DATA_PT_lens", "DATA_PT_context_light", "RENDER_PT_format", "RENDER_PT_output",
                   "RENDER_PT_color_management", "WORLD_PT_context_world", "MATERIAL_PT_custom_props",
                   "DATA_PT_vertex_groups")
EEVEE_ONLY = ("DATA_PT_EEVEE_light_shadow", "EEVEE_MATERIAL_PT_settings", "EEVEE_WORLD_PT_lightprobe",
              "DATA_PT_lightprobe_bake", "RENDER_PT_eevee_sampling")


def panels():
    out = {}
    for name in dir(bpy.types):
        cls = getattr(bpy.types, name, None)
        if isinstance(cls, type) and issubclass(cls, bpy.types.Panel) and isinstance(
                getattr(cls, "COMPAT_ENGINES", None), (set, frozenset)):
            out[name] = cls
    return out


def check_panels(before):
    now = panels()
    shown = {n for n, c in now.items() if "PTIR" in c.COMPAT_ENGINES}
    for n in COUNTERPARTS:
        h.check(n in now, "Blender %s has no panel %s" % (bpy.app.version_string, n))
        h.check(n in shown, "%s does not show under PTIR" % n)
    for n in CYCLES_BUILTINS:
        h.check(n in now and "CYCLES" in now[n].COMPAT_ENGINES, "%s is not a panel Cycles shows here" % n)
        h.check(n in shown, "%s (shown by Cycles) does not show under PTIR" % n)
    eevee_only = sorted(n for n in shown if n not in COUNTERPARTS and not n.startswith("RENDER_PT_ptir")
                        and "CYCLES" not in now[n].COMPAT_ENGINES
                        and now[n].COMPAT_ENGINES & {"BLENDER_EEVEE", "BLENDER_EEVEE_NEXT"})
    h.check(not eevee_only, "EEVEE-only panels shown under PTIR: %s" % eevee_only)
    h.check(not any(n in shown for n in EEVEE_ONLY), "an EEVEE-only panel shows under PTIR")
    cycles_own = sorted(n for n in shown if n.startswith(("CYCLES_", "NODE_CYCLES_")))
    h.check(not cycles_own, "Cycles' own panels shown under PTIR: %s" % cycles_own)
    # The render settings panels of the engine itself: on for PTIR, off for Cycles.
    scene = bpy.context.scene
    scene.render.engine = "PTIR"
    h.check(bpy.types.RENDER_PT_ptir_sampling.poll(bpy.context), "PTIR sampling panel hidden under PTIR")
    scene.render.engine = "CYCLES"
    h.check(not bpy.types.RENDER_PT_ptir_sampling.poll(bpy.context), "PTIR sampling panel shown under Cycles")
    print("panels: %d shown under PTIR; EEVEE's in place of Cycles' own: %s" % (len(shown), ", ".join(COUNTERPARTS)))
    return len(shown)


def check_restored(before):
    now = panels()
    changed = sorted(n for n, (ident, engines) in before.items()
                     if n in now and (id(now[n].COMPAT_ENGINES) != ident or frozenset(now[n].COMPAT_ENGINES) != engines))
    h.check(not changed, "COMPAT_ENGINES not restored after disabling: %s" % changed[:8])
    print("panels: every COMPAT_ENGINES restored on disable")


def check_engines():
    from ptir_blender.blender import compat
    render = bpy.context.scene.render
    expected = "BLENDER_EEVEE_NEXT" if (4, 2, 0) <= bpy.app.version < (5, 0, 0) else "BLENDER_EEVEE"
    h.check(compat.EEVEE_ENGINE == expected, "compat.EEVEE_ENGINE %s, expected %s" % (compat.EEVEE_ENGINE, expected))
    for engine in (compat.EEVEE_ENGINE, "PTIR", "CYCLES"):
        render.engine = engine
        h.check(render.engine == engine, "cannot set the render engine %s" % engine)
    print("engines: %s, PTIR, CYCLES" % compat.EEVEE_ENGINE)


def check_writeback():
    from ptir_blender.blender import compat, material_export, material_writeback
    model = compat.principled_model()
    h.check(model == ("principled-v2" if bpy.app.version >= (4, 0, 0) else "principled-v1"), "model %s" % model)
    params = {"shader": "principled", "base_color": [0.25, 0.5, 0.75], "roughness": 0.3, "metallic": 0.6}
    if model == "principled-v2":
        params.update({"ior": 1.33, "specular_ior_level": 0.8, "specular_tint_color": [1.0, 0.5, 0.25],
                       "diffuse_roughness": 0.4 if bpy.app.version >= (4, 3, 0) else 0.0})
        sockets = {"IOR": 1.33, "Specular IOR Level": 0.8, "Specular Tint": [1.0, 0.5, 0.25]}
        if bpy.app.version >= (4, 3, 0):
            sockets["Diffuse Roughness"] = 0.4
    else:
        params.update({"specular": 0.8, "specular_tint": 0.4})
        sockets = {"Specular": 0.8, "Specular Tint": 0.4}
    mat = bpy.data.materials.new("written")
    compat.ensure_nodes(mat)
    node = material_writeback.write_principled(mat, params)
    for name, v in sockets.items():
        got = node.inputs[name].default_value
        got = list(got)[:3] if hasattr(got, "__len__") else got
        h.check(np.allclose(got, v, atol=1e-6), "socket %s = %s, expected %s" % (name, got, v))
    h.check(node.distribution == "GGX", "distribution %s, expected GGX" % node.distribution)
    warns = []
    back = material_export.material_params(mat, warns)
    for k, v in params.items():
        h.check(np.allclose(back[k], v, atol=1e-6) if k != "shader" else back[k] == v,
                "written %s = %s read back as %s" % (k, v, back[k]))
    h.check(not warns, "warnings reading a written material: %s" % warns)
    # A material shaded by a Diffuse BSDF gets a Principled BSDF feeding its output.
    plain = bpy.data.materials.new("plain")
    tree = compat.ensure_nodes(plain)
    for n in list(tree.nodes):
        if n.type == "BSDF_PRINCIPLED":
            tree.nodes.remove(n)
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    out = next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL")
    tree.links.new(diffuse.outputs[0], out.inputs["Surface"])
    node = material_writeback.write_principled(plain, {**params, "shader": "principled-multiscatter"})
    h.check(material_export.output_surface_node(tree) == node, "the new Principled BSDF does not feed the output")
    h.check(node.distribution == "MULTI_GGX", "distribution %s, expected MULTI_GGX" % node.distribution)
    print("write-back: %s sockets %s set and read back" % (model, ", ".join(sockets)))
    return model


def check_splat_attributes(tmp):
    from ptir_blender.blender import splat_object
    ply = ac.write_ply(os.path.join(tmp, "attrs.ply"), ac.random_raw(40, material=True, seed=5))
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=str(ply))
    h.check(r == {"FINISHED"}, "import")
    mesh = bpy.context.active_object.data
    names = {a.name for a in mesh.attributes}
    wanted = {"scale", "rotation", "radiance:base"} | {"radiance:sh_%d" % k for k in range(15)}
    if bpy.app.version >= (3, 5, 0):  # (3.4 keeps vertex positions outside the generic attributes)
        wanted.add("position")
    h.check(wanted <= names, "missing native splat attributes %s" % sorted(wanted - names))
    h.check(mesh.attributes["rotation"].data_type == splat_object.ROTATION_TYPE, "rotation type")
    print("splat object: position, scale, rotation (%s), radiance:base, radiance:sh_0..14" % splat_object.ROTATION_TYPE)


def export_scene(tmp):
    from ptir_blender.blender import compat, scene_export
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, -2.0))
    cube = bpy.context.active_object
    mat = bpy.data.materials.new("cube")
    compat.ensure_nodes(mat)
    cube.data.materials.append(mat)
    light = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
    bpy.context.scene.collection.objects.link(light)
    compat.ensure_nodes(bpy.context.scene.world)
    with open(scene_export.export_scene(bpy.context, os.path.join(tmp, "export"))) as f:
        doc = json.load(f)
    h.check(doc["brdf"] == compat.scene_brdf(), "scene brdf %s" % doc.get("brdf"))
    return doc["brdf"]


def main():
    import addon_utils
    tmp = h.argv()[0]
    before = {n: (id(c.COMPAT_ENGINES), frozenset(c.COMPAT_ENGINES)) for n, c in panels().items()}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        h.enable_addon()
        n_shown = check_panels(before)
        check_engines()
        check_splat_attributes(tmp)
        brdf = export_scene(tmp)
        model = check_writeback()
        bpy.context.scene.render.engine = "PTIR"
        addon_utils.disable("ptir_blender", default_set=True)
    check_restored(before)
    ours = [w for w in caught if issubclass(w.category, (DeprecationWarning, PendingDeprecationWarning, FutureWarning))
            and os.path.abspath(w.filename).startswith(REPO_FILES)]
    for w in caught:
        print("warning: %s:%d: %s: %s" % (w.filename, w.lineno, w.category.__name__, w.message))
    h.check(not ours, "deprecation warnings from the add-on: %s"
            % ["%s:%d %s" % (os.path.basename(w.filename), w.lineno, w.message) for w in ours])
    print("VERSIONS_STATS: " + json.dumps({"blender": bpy.app.version_string, "model": model, "scene_brdf": brdf,
                                           "panels_shown": n_shown, "warnings": len(caught)}))


h.run(main)
