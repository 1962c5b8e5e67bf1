"""Blender scene -> PTIR scene file (docs/scene_format.md).

    from ptir_blender.blender.scene_export import export_scene
    path = export_scene(bpy.context, "/tmp/out")       # -> /tmp/out/scene.json

What is exported (and how it maps; everything in Blender's units, converted by
the engine exactly as Cycles does):
  - Mesh objects (and curves/text/surfaces that evaluate to meshes): the evaluated
    mesh (modifiers applied), triangulated (loop triangles), in world space
    (matrix_world applied), one binary PLY per object and material slot used,
    with that slot's material:
        Principled BSDF -> shader "principled" (distribution GGX) or
                           "principled-multiscatter" (Multiscatter GGX), base_color
                           (linear), roughness, metallic, specular, specular_tint;
                           Emission x Emission Strength -> emission. The engine's
                           default model is Cycles' Principled v1 (Blender 3.x)
        Diffuse BSDF    -> shader "diffuse" (Oren-Nayar), base_color, roughness
        Glossy BSDF     -> base_color, roughness, metallic 1
        Emission        -> emission = Color x Strength, base_color black
        Mix / Add Shader-> the inputs' parameters mixed by Fac (Add: summed emission)
        anything else   -> the material's viewport colour / roughness / metallic
    Custom properties on the material override the conversion: ptir_base_color
    (3 floats), ptir_roughness, ptir_metallic, ptir_emission (3 floats).
    A socket driven by a texture or other node uses its unlinked default value (warned).
  - Objects carrying a custom property "ptir_gaussians" (a 3DGS .ply path) are
    exported as Gaussians with their world matrix as the transform (no mesh); a
    non-uniform scale or shear is folded into a world-space copy of the PLY instead
    (gaussians_entry; the rule is io/splat_transform.py's).
  - Lights: POINT (position, Power, Color, Radius), SUN (matrix, Strength, Color,
    Angle), AREA (matrix, Shape, Size, Size Y, Power, Color). SPOT lights are not
    supported (skipped with a warning).
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

from ..io import mesh_ply, scene_file, splat_ply, splat_transform
from ..errors import ExportError


def _safe_name(name):
    keep = "".join(c if (c.isalnum() or c in "-_.") else "_" for c in name)
    return keep or "object"


def _rgb(v):
    return [float(v[0]), float(v[1]), float(v[2])]


def _clamp01(x):
    return min(1.0, max(0.0, float(x)))


# ---------------------------------------------------------------- materials

DEFAULT_MATERIAL = {"shader": "principled", "base_color": [0.8, 0.8, 0.8], "roughness": 0.5, "metallic": 0.0,
                    "specular": 0.5, "specular_tint": 0.0}


def _principled_shader(node):
    """The engine shader name of a Principled BSDF node's distribution."""
    return "principled-multiscatter" if getattr(node, "distribution", "GGX") == "MULTI_GGX" else "principled"


def _optional_float(node, name, default, warnings, what):
    """A socket's value when the node has that socket (Blender 3.x names), else default."""
    if node.inputs.get(name) is None:
        return default
    v = _socket_value(node, name, warnings, what)
    return default if v is None else float(v)


def _socket_value(node, name, warnings, what):
    sock = node.inputs.get(name)
    if sock is None:
        return None
    if sock.is_linked:
        warnings.append("%s: '%s' input of %s is driven by a node; its default value is used" % (what, name, node.name))
    return sock.default_value


def _output_surface_node(tree):
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"]
    if not outputs:
        return None
    active = [n for n in outputs if n.is_active_output and n.target in ("ALL", "CYCLES")]
    out = (active or [n for n in outputs if n.target in ("ALL", "CYCLES")] or outputs)[0]
    sock = out.inputs.get("Surface")
    if sock is None or not sock.is_linked:
        return None
    return sock.links[0].from_node


def _shader_params(node, warnings, what, depth=0):
    """Parameters of the shader graph rooted at node, or None when it is not understood."""
    if node is None or depth > 16:
        return None
    t = node.type
    if t == "REROUTE":
        sock = node.inputs[0]
        return _shader_params(sock.links[0].from_node if sock.is_linked else None, warnings, what, depth + 1)
    if t == "BSDF_PRINCIPLED":
        p = {"shader": _principled_shader(node),
             "base_color": _rgb(_socket_value(node, "Base Color", warnings, what)),
             "roughness": float(_socket_value(node, "Roughness", warnings, what)),
             "metallic": float(_socket_value(node, "Metallic", warnings, what)),
             "specular": _optional_float(node, "Specular", 0.5, warnings, what),
             "specular_tint": _optional_float(node, "Specular Tint", 0.0, warnings, what),
             "emission": [0.0, 0.0, 0.0]}
        em = _socket_value(node, "Emission", warnings, what)
        strength = _socket_value(node, "Emission Strength", warnings, what)
        if em is not None:
            s = 1.0 if strength is None else float(strength)
            p["emission"] = [float(em[i]) * s for i in range(3)]
        for name, default in (("Transmission", 0.0), ("Subsurface", 0.0), ("Clearcoat", 0.0), ("Sheen", 0.0)):
            v = _socket_value(node, name, warnings, what)
            if v is not None and float(v) != default:
                warnings.append("%s: Principled %s = %g is not modelled (ignored)" % (what, name, float(v)))
        return p
    if t == "BSDF_DIFFUSE":
        return {"shader": "diffuse", "base_color": _rgb(_socket_value(node, "Color", warnings, what)),
                "roughness": float(_socket_value(node, "Roughness", warnings, what)), "metallic": 0.0,
                "emission": [0.0, 0.0, 0.0]}
    if t in ("BSDF_GLOSSY", "BSDF_ANISOTROPIC"):
        return {"base_color": _rgb(_socket_value(node, "Color", warnings, what)),
                "roughness": float(_socket_value(node, "Roughness", warnings, what)), "metallic": 1.0,
                "emission": [0.0, 0.0, 0.0]}
    if t == "EMISSION":
        c = _socket_value(node, "Color", warnings, what)
        s = float(_socket_value(node, "Strength", warnings, what))
        return {"base_color": [0.0, 0.0, 0.0], "roughness": 1.0, "metallic": 0.0,
                "emission": [float(c[i]) * s for i in range(3)]}
    if t in ("MIX_SHADER", "ADD_SHADER"):
        shader_inputs = [s for s in node.inputs if s.type == "SHADER"]
        parts = [_shader_params(s.links[0].from_node, warnings, what, depth + 1) if s.is_linked else None
                 for s in shader_inputs[:2]]
        if t == "MIX_SHADER":
            fac = _clamp01(_socket_value(node, "Fac", warnings, what))
            weights = [1.0 - fac, fac]
        else:
            weights = [1.0, 1.0]
        present = [(w, p) for w, p in zip(weights, parts) if p is not None]
        if not present:
            return None
        total = sum(w for w, _ in present)
        norm = [(w / total if total > 0 else 1.0 / len(present), p) for w, p in present]
        out = {"base_color": [sum(w * p["base_color"][i] for w, p in norm) for i in range(3)],
               "roughness": sum(w * p["roughness"] for w, p in norm),
               "metallic": sum(w * p["metallic"] for w, p in norm),
               "specular": sum(w * p.get("specular", 0.5) for w, p in norm),
               "specular_tint": sum(w * p.get("specular_tint", 0.0) for w, p in norm)}
        shaders = {p.get("shader", "principled") for _, p in norm}
        out["shader"] = shaders.pop() if len(shaders) == 1 else "principled"
        if t == "ADD_SHADER":
            out["emission"] = [sum(p["emission"][i] for _, p in present) for i in range(3)]
        else:
            out["emission"] = [sum(w * p["emission"][i] for w, p in zip(weights, parts) if p is not None)
                               for i in range(3)]
        warnings.append("%s: %s approximated by mixing its shaders' parameters" % (what, node.name))
        return out
    return None


def material_params(material, warnings=None):
    """The engine material (base_color, roughness, metallic, emission) of a Blender material."""
    warnings = [] if warnings is None else warnings
    if material is None:
        p = dict(DEFAULT_MATERIAL)
        p["emission"] = [0.0, 0.0, 0.0]
        return p
    what = "material '%s'" % material.name
    p = None
    overridden = all(k in material for k in ("ptir_base_color", "ptir_roughness", "ptir_metallic"))
    if overridden:
        p = {"base_color": _rgb(material["ptir_base_color"]), "roughness": 0.5, "metallic": 0.0,
             "emission": [0.0, 0.0, 0.0]}
    elif material.use_nodes and material.node_tree is not None:
        p = _shader_params(_output_surface_node(material.node_tree), warnings, what)
        if p is None:
            warnings.append("%s: surface shader not understood; using its viewport display values" % what)
    if p is None:
        p = {"base_color": _rgb(material.diffuse_color), "roughness": float(material.roughness),
             "metallic": float(material.metallic), "emission": [0.0, 0.0, 0.0]}
    # Explicit overrides.
    if "ptir_base_color" in material:
        p["base_color"] = _rgb(material["ptir_base_color"])
    if "ptir_roughness" in material:
        p["roughness"] = float(material["ptir_roughness"])
    if "ptir_metallic" in material:
        p["metallic"] = float(material["ptir_metallic"])
    if "ptir_emission" in material:
        p["emission"] = _rgb(material["ptir_emission"])
    for i in range(3):
        c = p["base_color"][i]
        if not 0.0 <= c <= 1.0:
            warnings.append("%s: base colour %r clamped to [0, 1]" % (what, p["base_color"]))
            p["base_color"] = [_clamp01(x) for x in p["base_color"]]
            break
    p["roughness"] = _clamp01(p["roughness"])
    p["metallic"] = _clamp01(p["metallic"])
    p["specular"] = min(max(float(p.get("specular", 0.5)), 0.0), 12.0)
    p["specular_tint"] = _clamp01(p.get("specular_tint", 0.0))
    p.setdefault("shader", "principled")
    p["emission"] = [max(0.0, float(x)) for x in p["emission"]]
    p["name"] = material.name
    return p


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


def _evaluated_triangles(obj, depsgraph):
    """World-space vertices (n, 3) float64, triangles (m, 3) int64, per-triangle material index
    and world-space corner normals (m, 3, 3) (None: flat faces)."""
    ev = obj.evaluated_get(depsgraph)
    mesh = ev.to_mesh()
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
        if normals is not None:
            loops = np.empty(nt * 3, np.int64)
            mesh.loop_triangles.foreach_get("loops", loops)
            normals = normals[loops]
    finally:
        ev.to_mesh_clear()
    m = np.array(obj.matrix_world, np.float64)
    co = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    if normals is not None:  # normals go by the inverse transpose
        normals = (normals @ np.linalg.inv(m[:3, :3])).reshape(-1, 3, 3)
    return co, tris.reshape(-1, 3), mat, normals


def export_mesh_object(obj, depsgraph, out_dir, warnings):
    """Writes one PLY per material slot used; returns the scene "meshes" entries."""
    co, tris, mat_index, corner_normals = _evaluated_triangles(obj, depsgraph)
    if len(tris) == 0:
        return []
    slots = obj.material_slots
    entries = []
    for idx in np.unique(mat_index):
        sel = tris[mat_index == idx]
        normals = None
        if corner_normals is not None:  # smooth shading: a vertex per distinct corner normal
            verts, normals, faces = mesh_ply.split_corners(co, sel, corner_normals[mat_index == idx])
        else:
            used, inverse = np.unique(sel.reshape(-1), return_inverse=True)
            verts = co[used]
            faces = inverse.reshape(-1, 3)
        material = slots[int(idx)].material if 0 <= int(idx) < len(slots) else None
        suffix = "" if len(slots) <= 1 else "_%d" % int(idx)
        fname = "mesh_%s%s.ply" % (_safe_name(obj.name), suffix)
        mesh_ply.write_mesh_ply(os.path.join(out_dir, fname), verts, faces, comment="PTIR export of %s" % obj.name,
                                normals=normals)
        entries.append({"name": obj.name + suffix, "file": fname, "material": material_params(material, warnings)})
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
        entry.update({"type": "sun", "transform": scene_file.matrix_rows(m), "strength": float(light.energy),
                      "angle": float(light.angle)})
    elif light.type == "AREA":
        entry.update({"type": "area", "shape": light.shape.lower(), "transform": scene_file.matrix_rows(m),
                      "size": float(light.size), "size_y": float(light.size_y), "power": float(light.energy)})
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

def _save_image_exr(image, path):
    """Writes a Blender image's float pixels to a linear EXR through the native module when
    available, else as a Radiance .hdr written with numpy (Image.save would display-encode)."""
    w, h = image.size
    px = np.empty(w * h * image.channels, np.float32)
    image.pixels.foreach_get(px)
    px = px.reshape(h, w, image.channels)[::-1, :, :3]  # Blender stores rows bottom-up
    root = os.path.splitext(path)[0]
    try:
        from .. import native
        ptir = native()
        ptir.write_image(root + ".exr", np.ascontiguousarray(px))
        return root + ".exr"
    except Exception:
        return write_rgbe(root + ".hdr", px)


def write_rgbe(path, rgb):
    """Flat (uncompressed) Radiance .hdr from float (h, w, 3), numpy only; row 0 = top."""
    rgb = np.maximum(np.asarray(rgb, np.float64), 0.0)
    h, w, _ = rgb.shape
    v = rgb.max(axis=2)
    m, e = np.frexp(v)
    scale = np.where(v > 1e-32, m * 256.0 / np.maximum(v, 1e-32), 0.0)
    out = np.zeros((h, w, 4), np.uint8)
    out[..., :3] = np.clip(rgb * scale[..., None], 0, 255).astype(np.uint8)
    out[..., 3] = np.where(v > 1e-32, e + 128, 0).astype(np.uint8)
    with open(path, "wb") as f:
        f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n")
        f.write(("-Y %d +X %d\n" % (h, w)).encode("ascii"))
        f.write(out.tobytes())
    return path


def world_entry(world, out_dir, warnings):
    if world is None:
        return None
    if not world.use_nodes or world.node_tree is None:
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
        path = _save_image_exr(image, os.path.join(out_dir, "environment_%s.exr" % _safe_name(image.name)))
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
           "comment": "exported from Blender %s scene '%s'" % (bpy.app.version_string, scene.name)}
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
