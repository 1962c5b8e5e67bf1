"""Blender scene -> PTIR scene file (docs/scene_format.md).

    from ptir_blender.blender.scene_export import export_scene
    path = export_scene(bpy.context, "/tmp/out")       # -> /tmp/out/scene.json

What is exported (and how it maps; everything in Blender's units, converted by
the engine exactly as Cycles does):
  - Mesh objects (and curves/text/surfaces that evaluate to meshes): the evaluated
    mesh (modifiers applied), triangulated (loop triangles), in world space
    (matrix_world applied), one binary PLY per object and material slot used,
    with that slot's material (material_export.py: the Principled BSDF read by this Blender's
    socket names, as the engine model of this Blender -- principled-v1 on 3.x, principled-v2 on
    4.0+ -- Diffuse, Glossy, Emission, Mix / Add Shader; what the engine does not render is
    reported as a warning naming the material and the socket).
  - The scene's "brdf": the engine model of this Blender's Principled BSDF (compat.scene_brdf()).
  - Objects carrying a custom property "ptir_gaussians" (a 3DGS .ply path) are
    exported as Gaussians with their world matrix as the transform (no mesh); a
    non-uniform scale or shear is folded into a world-space copy of the PLY instead
    (gaussians_entry; the rule is io/splat_transform.py's).
  - Lights: POINT (position, Power, Color, Radius), SUN (matrix, Strength, Color,
    Angle), AREA (matrix, Shape, Size, Size Y, Power, Color), in the scene file's units
    (Cycles 3.x's; io/light_units.py converts 4.0+'s area power and angled suns). SPOT
    lights are not supported (skipped with a warning).
  - World: Background node -> Strength; its Color from an Environment Texture
    (the image file; a packed or generated image is written to an .exr next to the
    scene) with an optional Mapping node's Z rotation, or a constant colour.
    No world or no nodes: world.color.
  - Cameras: the scene camera first, then every other camera object: matrix_world
    (scale removed), horizontal FOV from lens, sensor and sensor fit, the render
    resolution times its percentage.
Objects hidden from render (hide_render) or not in the view layer are skipped.

export_scene returns the path of the JSON file; warnings (things approximated or
skipped) are collected in the `warnings` list argument when given, and printed.
"""

import math
import os

import bpy
import numpy as np

from ..io import light_units, mesh_ply, scene_file, splat_ply, splat_transform
from . import compat, image_files, material_export
from ..errors import ExportError


def _safe_name(name):
    keep = "".join(c if (c.isalnum() or c in "-_.") else "_" for c in name)
    return keep or "object"


def _rgb(v):
    return [float(v[0]), float(v[1]), float(v[2])]


# ---------------------------------------------------------------- materials (material_export.py)

DEFAULT_MATERIAL = material_export.default_material()
material_params = material_export.material_params


# ---------------------------------------------------------------- meshes

def _corner_normals(mesh):
    """Per-corner (loop) normals (n_loops, 3) as Cycles shades them (smooth, flat, auto smooth,
    custom split normals), or None when every face is flat and none is custom."""
    smooth = np.zeros(len(mesh.polygons), bool)
    mesh.polygons.foreach_get("use_smooth", smooth)
    if not smooth.any() and not mesh.has_custom_normals:
        return None
    ln = np.empty(len(mesh.loops) * 3, np.float64)
    if hasattr(mesh, "corner_normals"):  # Blender 4.1+
        mesh.corner_normals.foreach_get("vector", ln)
    else:
        mesh.calc_normals_split()
        mesh.loops.foreach_get("normal", ln)
    return ln.reshape(-1, 3)


def _uv_layer(mesh, name, warnings, what):
    """The mesh's UV map called name ("": the render-active one, as Cycles' default), or None."""
    layers = mesh.uv_layers
    warnings = [] if warnings is None else warnings
    if not len(layers):
        warnings.append("%s has image textures but no UV map; they read UV (0, 0) as in Cycles" % what)
        return None
    if name:
        if name not in layers:
            warnings.append("%s has no UV map '%s'; the default one is used" % (what, name))
        else:
            return layers[name]
    return next((l for l in layers if l.active_render), layers.active or layers[0])


def _corner_uvs_tangents(mesh, uv_name, want_tangents, warnings, what):
    """Per-loop UVs (n_loops, 2) and MikkTSpace tangents with bitangent sign (n_loops, 4) (None when
    not wanted or not computable) of a UV map."""
    layer = _uv_layer(mesh, uv_name, warnings, what)
    if layer is None:
        return None, None
    uv = np.empty(len(mesh.loops) * 2, np.float64)
    layer.data.foreach_get("uv", uv)
    tangents = None
    if want_tangents:
        try:
            mesh.calc_tangents(uvmap=layer.name)
            t = np.empty(len(mesh.loops) * 3, np.float64)
            sign = np.empty(len(mesh.loops), np.float64)
            mesh.loops.foreach_get("tangent", t)
            mesh.loops.foreach_get("bitangent_sign", sign)
            tangents = np.concatenate([t.reshape(-1, 3), sign[:, None]], axis=1)
        except RuntimeError as e:  # n-gons: the engine derives tangents from the UVs
            warnings.append("%s: Blender cannot compute tangents (%s); the engine derives them from the UVs"
                            % (what, str(e).strip()))
        finally:
            if hasattr(mesh, "free_tangents"):
                mesh.free_tangents()
    return uv.reshape(-1, 2), tangents


def _evaluated_triangles(obj, depsgraph, uv_request=None, warnings=None):
    """World-space vertices (n, 3) float64, triangles (m, 3) int64, per-triangle material index,
    world-space corner normals (m, 3, 3) (None: flat faces), corner UVs (m, 3, 2) and corner
    tangents with sign (m, 3, 4) (None unless uv_request = (uv map name, tangents wanted))."""
    ev = obj.evaluated_get(depsgraph)
    mesh = ev.to_mesh()
    uvs = tangents = None
    try:
        mesh.calc_loop_triangles()
        nv, nt = len(mesh.vertices), len(mesh.loop_triangles)
        co = np.empty(nv * 3, np.float64)
        mesh.vertices.foreach_get("co", co)
        tris = np.empty(nt * 3, np.int64)
        mesh.loop_triangles.foreach_get("vertices", tris)
        mat = np.empty(nt, np.int64)
        mesh.loop_triangles.foreach_get("material_index", mat)
        normals = _corner_normals(mesh)
        loops = np.empty(nt * 3, np.int64)
        mesh.loop_triangles.foreach_get("loops", loops)
        if normals is not None:
            normals = normals[loops]
        if uv_request is not None:
            uvs, tangents = _corner_uvs_tangents(mesh, uv_request[0], uv_request[1], warnings,
                                                 "object '%s'" % obj.name)
            uvs = None if uvs is None else uvs[loops].reshape(-1, 3, 2)
            tangents = None if tangents is None else tangents[loops]
    finally:
        ev.to_mesh_clear()
    m = np.array(obj.matrix_world, np.float64)
    co = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    if normals is not None:  # normals go by the inverse transpose
        normals = (normals @ np.linalg.inv(m[:3, :3])).reshape(-1, 3, 3)
    if tangents is not None:  # tangents are surface directions; a mirror flips the bitangent's sign
        t = tangents[:, :3] @ m[:3, :3].T
        t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-30)
        sign = tangents[:, 3:] * (-1.0 if np.linalg.det(m[:3, :3]) < 0 else 1.0)
        tangents = np.concatenate([t, sign], axis=1).reshape(-1, 3, 4)
    return co, tris.reshape(-1, 3), mat, normals, uvs, tangents


def _uv_request(materials, warnings, what):
    """(uv map name, tangents wanted) the slots' textures need, or None without textures; the
    parameters of each slot's material (the UV map is the first one named; others are reported)."""
    params, names = [], []
    for material in materials:
        uv_maps = []
        params.append(material_params(material, warnings, uv_maps=uv_maps))
        names += uv_maps
    textured = [p for p in params if material_export.texture_export.uses_textures(p)]
    if not textured:
        return params, None
    if len(set(names)) > 1:
        warnings.append("%s: its textures read UV maps %s; the engine reads one UV map per mesh ('%s')"
                        % (what, sorted(set(names)), names[0]))
    return params, (names[0] if names else "", any("normal_map" in p for p in textured))


def export_mesh_object(obj, depsgraph, out_dir, warnings):
    """Writes one PLY per material slot used; returns the scene "meshes" entries."""
    slots = obj.material_slots
    materials = [s.material for s in slots] or [None]
    params, uv_request = _uv_request(materials, warnings, "object '%s'" % obj.name)
    co, tris, mat_index, corner_normals, corner_uvs, corner_tangents = _evaluated_triangles(
        obj, depsgraph, uv_request, warnings)
    if len(tris) == 0:
        return []
    entries = []
    for idx in np.unique(mat_index):
        sel = tris[mat_index == idx]
        here = mat_index == idx
        attrs = {"normals": None if corner_normals is None else corner_normals[here],
                 "uvs": None if corner_uvs is None else corner_uvs[here],
                 "tangents": None if corner_tangents is None else corner_tangents[here]}
        if any(a is not None for a in attrs.values()):
            # A vertex per distinct corner (normal, UV, tangent): sharp edges and UV seams stay sharp.
            verts, split, faces = mesh_ply.split_corner_attributes(co, sel, **attrs)
            if "normals" in split:
                split["normals"] /= np.maximum(np.linalg.norm(split["normals"], axis=1, keepdims=True), 1e-30)
        else:
            used, inverse = np.unique(sel.reshape(-1), return_inverse=True)
            verts, split = co[used], {}
            faces = inverse.reshape(-1, 3)
        k = int(idx) if 0 <= int(idx) < len(slots) else -1
        material = params[k] if k >= 0 else (params[0] if not len(slots) else material_params(None, warnings))
        suffix = "" if len(slots) <= 1 else "_%d" % int(idx)
        fname = "mesh_%s%s.ply" % (_safe_name(obj.name), suffix)
        mesh_ply.write_mesh_ply(os.path.join(out_dir, fname), verts, faces, comment="PTIR export of %s" % obj.name,
                                normals=split.get("normals"), uvs=split.get("uvs"), tangents=split.get("tangents"))
        entries.append({"name": obj.name + suffix, "file": fname, "material": material})
    return entries


# ---------------------------------------------------------------- lights

def light_entry(obj, warnings):
    light = obj.data
    m = obj.matrix_world
    entry = {"name": obj.name, "color": _rgb(light.color)}
    if light.type == "POINT":
        entry.update({"type": "point", "position": [float(x) for x in m.translation], "power": float(light.energy),
                      "radius": float(light.shadow_soft_size)})
    elif light.type == "SUN":
        entry.update({"type": "sun", "transform": scene_file.matrix_rows(m),
                      "strength": light_units.sun_strength(light.energy, light.angle, bpy.app.version),
                      "angle": float(light.angle)})
    elif light.type == "AREA":
        entry.update({"type": "area", "shape": light.shape.lower(), "transform": scene_file.matrix_rows(m),
                      "size": float(light.size), "size_y": float(light.size_y),
                      "power": light_units.area_power(light.energy, bpy.app.version)})
        spread = getattr(light, "spread", math.pi)
        if abs(spread - math.pi) > 1e-4:
            warnings.append("light '%s': Spread %.1f deg is not modelled (180 deg used)" % (obj.name, math.degrees(spread)))
    else:
        warnings.append("light '%s': %s lights are not supported (skipped)" % (obj.name, light.type))
        return None
    if light.use_nodes:
        warnings.append("light '%s': light node trees are ignored" % obj.name)
    # Ray Visibility > Camera (off by default in Blender 3.4): the engine honours it.
    entry["visible_camera"] = bool(getattr(obj, "visible_camera", False))
    return entry


# ---------------------------------------------------------------- world

def world_entry(world, out_dir, warnings):
    if world is None:
        return None
    if not compat.uses_nodes(world):
        c = _rgb(world.color)
        return {"type": "color", "color": c, "strength": 1.0} if any(c) else None
    tree = world.node_tree
    outs = [n for n in tree.nodes if n.type == "OUTPUT_WORLD"]
    active = [n for n in outs if n.is_active_output] or outs
    if not active or not active[0].inputs["Surface"].is_linked:
        return None
    bg = active[0].inputs["Surface"].links[0].from_node
    if bg.type != "BACKGROUND":
        warnings.append("world: surface is %s, not a Background node; exported black" % bg.type)
        return None
    strength = float(bg.inputs["Strength"].default_value)
    if bg.inputs["Strength"].is_linked:
        warnings.append("world: Background Strength is driven by a node; its default value is used")
    col = bg.inputs["Color"]
    if not col.is_linked:
        return {"type": "color", "color": _rgb(col.default_value), "strength": strength}
    tex = col.links[0].from_node
    if tex.type != "TEX_ENVIRONMENT" or tex.image is None:
        warnings.append("world: Background Color is driven by %s; its default colour is used" % tex.type)
        return {"type": "color", "color": _rgb(col.default_value), "strength": strength}
    if tex.projection != "EQUIRECTANGULAR":
        raise ExportError("world: Environment Texture projection %s is not supported (equirectangular only)"
                          % tex.projection)
    image = tex.image
    rotation_z = 0.0
    vec = tex.inputs["Vector"]
    if vec.is_linked:
        mapping = vec.links[0].from_node
        if mapping.type == "MAPPING":
            rot = mapping.inputs["Rotation"].default_value
            loc = mapping.inputs["Location"].default_value
            scl = mapping.inputs["Scale"].default_value
            if abs(rot[0]) > 1e-6 or abs(rot[1]) > 1e-6 or any(abs(s - 1.0) > 1e-6 for s in scl):
                warnings.append("world: only the Mapping node's Z rotation is exported")
            rotation_z = float(rot[2])
            if mapping.vector_type == "TEXTURE":
                rotation_z = -rotation_z  # the inverse transform
            elif mapping.vector_type not in ("POINT", "VECTOR"):
                warnings.append("world: Mapping type %s treated as Point" % mapping.vector_type)
        else:
            warnings.append("world: Environment Texture vector from %s ignored (default mapping used)"
                            % mapping.type)
    path = bpy.path.abspath(image.filepath_raw or image.filepath) if image.source == "FILE" else ""
    if image.packed_file is not None or not path or not os.path.exists(path):
        path = image_files.save_image_exr(image, os.path.join(out_dir, "environment_%s.exr" % _safe_name(image.name)))
    cs = image.colorspace_settings.name
    if cs not in ("Linear", "Linear Rec.709", "Non-Color", "Raw") and image.is_float is False:
        warnings.append("world: environment image '%s' is in %s; the engine decodes 8-bit files as sRGB"
                        % (image.name, cs))
    return {"type": "latlong", "file": scene_file.relative_path(path, out_dir), "strength": strength,
            "rotation_z": rotation_z}


# ---------------------------------------------------------------- cameras

def camera_entry(obj, scene, warnings):
    cam = obj.data
    if cam.type != "PERSP":
        warnings.append("camera '%s': %s cameras are not supported (skipped)" % (obj.name, cam.type))
        return None
    r = scene.render
    width, height = scene_file.render_size(r.resolution_x, r.resolution_y, r.resolution_percentage)
    if abs(r.pixel_aspect_x - r.pixel_aspect_y) > 1e-6:
        warnings.append("camera '%s': non-square pixels are not supported" % obj.name)
    if abs(cam.shift_x) > 1e-6 or abs(cam.shift_y) > 1e-6:
        warnings.append("camera '%s': lens shift is not supported (ignored)" % obj.name)
    # lens and sensor are always set, whatever unit (millimetres or field of view) the UI shows
    fov_x = scene_file.horizontal_fov(cam.lens, cam.sensor_width, cam.sensor_height, cam.sensor_fit, width, height,
                                      r.pixel_aspect_x, r.pixel_aspect_y)
    m = obj.matrix_world.normalized()  # drop scale: rays stay unit length
    rows = scene_file.matrix_rows(m)
    rows[3] = [0.0, 0.0, 0.0, 1.0]
    return {"name": obj.name, "transform": rows, "fov_x": fov_x, "width": width, "height": height}


# ---------------------------------------------------------------- Gaussians by reference

def gaussians_entry(obj, out_dir):
    """The "gaussians" entry of an object whose "ptir_gaussians" property names a splat PLY.

    The transform rule is io/splat_transform.py's: a similarity is written as the entry's
    transform (the engine applies it, as transform_splats would); anything else (a non-uniform
    scale, a shear) the engine refuses, so the splats are folded here into a world-space PLY
    in out_dir.
    """
    path = bpy.path.abspath(str(obj["ptir_gaussians"]))
    matrix = np.array(obj.matrix_world, np.float64)
    if splat_transform.is_similarity(matrix):
        return {"file": scene_file.relative_path(path, out_dir), "transform": scene_file.matrix_rows(matrix)}
    d = splat_transform.transform_splats(splat_ply.read_splat_ply(path), matrix,
                                         what="object '%s': its transform" % obj.name)
    fname = "gaussians_%s.ply" % _safe_name(obj.name)
    splat_ply.write_splat_ply(os.path.join(out_dir, fname), d,
                              comment="PTIR export of %s (%s, transform folded in)" % (obj.name, path))
    return {"file": fname}


# ---------------------------------------------------------------- scene

def _visible_objects(scene, view_layer):
    for obj in scene.objects:
        if obj.hide_render:
            continue
        if view_layer is not None and obj.name not in view_layer.objects:
            continue
        yield obj


# Cycles' Film > Pixel Filter (Blender's default: Blackman-Harris, 1.5 px): the
# engine draws its camera samples from the same filter, with Cycles' width convention.
_PIXEL_FILTERS = {"BLACKMAN_HARRIS": "blackman_harris", "GAUSSIAN": "gaussian", "BOX": "box"}


def film_filter(scene):
    """{"pixel_filter", "filter_width"} of the scene's Cycles film; {} without the Cycles add-on."""
    cy = getattr(scene, "cycles", None)
    if cy is None or not hasattr(cy, "filter_width"):
        return {}
    return {"pixel_filter": _PIXEL_FILTERS.get(getattr(cy, "pixel_filter_type", ""), "blackman_harris"),
            "filter_width": float(cy.filter_width)}


def light_paths(scene):
    """Cycles' Light Paths settings the integrator follows beyond the bounce count: Min Light
    Bounces (the vertices before Russian roulette starts)."""
    cy = getattr(scene, "cycles", None)
    if cy is None or not hasattr(cy, "min_light_bounces"):
        return {}
    return {"min_light_bounces": int(cy.min_light_bounces)}


def cycles_integrator(scene):
    """The integrator settings a scene's Cycles settings imply (pixel filter, Min Light Bounces);
    what an export writes before the caller's own settings."""
    return {**film_filter(scene), **light_paths(scene)}


def export_scene(context_or_scene, out_dir, scene_name="scene.json", integrator=None, objects=None,
                 warnings=None, include_cameras=True):
    """Exports the Blender scene to out_dir (created); returns the scene file's path.

    context_or_scene: bpy.context (its scene and view layer) or a bpy.types.Scene.
    integrator: dict of integrator settings to write (spp, bounces, ...); the film's pixel filter is
        always added (the dict's own pixel_filter / filter_width win).
    objects: restrict mesh/light export to these objects (default: all visible).
    warnings: a list that receives messages about approximations and skipped items.
    """
    if isinstance(context_or_scene, bpy.types.Scene):
        scene = context_or_scene
        view_layer = scene.view_layers[0] if len(scene.view_layers) else None
    else:
        scene = context_or_scene.scene
        view_layer = context_or_scene.view_layer
    warnings = [] if warnings is None else warnings
    os.makedirs(out_dir, exist_ok=True)
    depsgraph = view_layer.depsgraph if view_layer is not None else bpy.context.evaluated_depsgraph_get()
    if view_layer is not None:
        view_layer.update()
    candidates = list(objects) if objects is not None else list(_visible_objects(scene, view_layer))

    doc = {"version": scene_file.FORMAT_VERSION,
           "comment": "exported from Blender %s scene '%s'" % (bpy.app.version_string, scene.name),
           "brdf": compat.scene_brdf()}
    gaussians, meshes, lights = [], [], []
    for obj in candidates:
        if "ptir_gaussians" in obj:
            gaussians.append(gaussians_entry(obj, out_dir))
        elif obj.type == "LIGHT":
            e = light_entry(obj, warnings)
            if e is not None:
                lights.append(e)
        elif obj.type in ("MESH", "CURVE", "SURFACE", "META", "FONT"):
            meshes.extend(export_mesh_object(obj, depsgraph, out_dir, warnings))
    if gaussians:
        doc["gaussians"] = gaussians
    if meshes:
        doc["meshes"] = meshes
    if lights:
        doc["lights"] = lights
    env = world_entry(scene.world, out_dir, warnings)
    if env is not None:
        doc["environment"] = env
    if include_cameras:
        cams = []
        ordered = ([scene.camera] if scene.camera is not None else []) + sorted(
            (o for o in scene.objects if o.type == "CAMERA" and o != scene.camera), key=lambda o: o.name)
        for obj in ordered:
            e = camera_entry(obj, scene, warnings)
            if e is not None:
                cams.append(e)
        if cams:
            doc["cameras"] = cams
        else:
            warnings.append("no (perspective) camera: the scene file has none")
    integrator = {**cycles_integrator(scene), **(integrator or {})}
    if integrator:
        doc["integrator"] = integrator
    path = scene_file.write_scene(os.path.join(out_dir, scene_name), doc)
    for w in warnings:
        print("ptir export: warning: %s" % w)
    return path
