"""Blender materials -> the engine's mesh materials (the "material" of a scene file's mesh entry).

    material_params(material, warnings)   # -> {"shader", "base_color", "roughness", "metallic", ..., "name"}

The fields follow the engine model of the Blender the add-on runs in (compat.principled_model()):
  principled-v1 (Blender 3.x): specular, specular_tint (floats; docs/PRINCIPLED.md)
  principled-v2 (Blender 4.0+): ior, specular_ior_level, specular_tint_color (RGB), diffuse_roughness
and, in both, shader ("principled" = GGX, "principled-multiscatter" = Multiscatter GGX, "diffuse" =
the Diffuse BSDF's Oren-Nayar), base_color (linear), roughness, metallic, emission (colour x strength).
Principled sockets are read by name, per version (compat.PRINCIPLED_SOCKETS).

Node graphs understood: Principled BSDF; Diffuse BSDF (shader "diffuse"); Glossy / Anisotropic BSDF
(metallic 1); Emission (emission, black base); Mix / Add Shader (the inputs' parameters mixed by Fac;
Add sums emission); Reroute. Anything else: the material's viewport colour / roughness / metallic.
Custom properties on the material override the conversion: ptir_base_color (3 floats), ptir_roughness,
ptir_metallic, ptir_emission (3 floats).

Image textures (blender/texture_export.py): an Image Texture linked to Base Color, Roughness or Metallic
becomes the field's texture entry, a tangent-space Normal Map node with an Image Texture on Normal the
"normal_map" entry; any other node there is reported by a warning and the socket's value used.

Nothing is dropped silently: a socket driven by another node uses its unlinked default value,
and a Principled layer the engine does not render (v2: Coat, Sheen, Transmission, Subsurface Weight,
Alpha < 1, Anisotropic, Thin Film; v1: Transmission, Subsurface, Clearcoat, Sheen) is left out; each adds
a warning naming the material and the socket, which the export report and the operators' reports show.
"""

from . import compat, texture_export

V1_FIELDS = {"specular": 0.5, "specular_tint": 0.0}
V2_FIELDS = {"ior": 1.5, "specular_ior_level": 0.5, "specular_tint_color": [1.0, 1.0, 1.0], "diffuse_roughness": 0.0}
COMMON = {"shader": "principled", "base_color": [0.8, 0.8, 0.8], "roughness": 0.5, "metallic": 0.0,
          "emission": [0.0, 0.0, 0.0]}

# Principled inputs the engine does not render, with the value at which they have no effect.
UNRENDERED = {
    "principled-v1": (("Transmission", 0.0), ("Subsurface", 0.0), ("Clearcoat", 0.0), ("Sheen", 0.0)),
    "principled-v2": (("Coat Weight", 0.0), ("Sheen Weight", 0.0), ("Transmission Weight", 0.0),
                      ("Subsurface Weight", 0.0), ("Alpha", 1.0), ("Anisotropic", 0.0), ("Thin Film Thickness", 0.0)),
}


def model_fields(model):
    """The model-specific fields and their defaults (those of a new Principled BSDF of that Blender)."""
    return V2_FIELDS if model == "principled-v2" else V1_FIELDS


def default_material(model=None):
    """The engine material of a mesh without a material."""
    model = model or compat.principled_model()
    return {**COMMON, **{k: (list(v) if isinstance(v, list) else v) for k, v in model_fields(model).items()}}


def _rgb(v):
    return [float(v[0]), float(v[1]), float(v[2])]


def _clamp01(x):
    return min(1.0, max(0.0, float(x)))


def _principled_shader(node):
    """The engine shader name of a Principled BSDF node's distribution."""
    return "principled-multiscatter" if getattr(node, "distribution", "GGX") == "MULTI_GGX" else "principled"


def _socket_value(node, name, warnings, what):
    sock = node.inputs.get(name)
    if sock is None:
        return None
    if sock.is_linked:
        warnings.append("%s: '%s' input of %s is driven by a node; its default value is used" % (what, name, node.name))
    return sock.default_value


def _optional_float(node, name, default, warnings, what):
    """A socket's value when the node has that socket (it differs between versions), else default."""
    v = _socket_value(node, name, warnings, what)
    return default if v is None else float(v)


def _unrendered(node, model, warnings, what):
    for name, neutral in UNRENDERED[model]:
        sock = node.inputs.get(name)
        if sock is None:
            continue
        if sock.is_linked:
            warnings.append("%s: Principled '%s' is driven by a node; the engine does not render it (ignored)"
                            % (what, name))
        elif abs(float(sock.default_value) - neutral) > 1e-6:
            warnings.append("%s: Principled '%s' = %g is not rendered by the engine (ignored)"
                            % (what, name, float(sock.default_value)))


def _emission(node, colour_socket, warnings, what):
    em = _socket_value(node, colour_socket, warnings, what)
    strength = _socket_value(node, "Emission Strength", warnings, what)
    if em is None:
        return [0.0, 0.0, 0.0]
    s = 1.0 if strength is None else float(strength)
    return [float(em[i]) * s for i in range(3)]


def _textured_inputs(node, p, warnings, what, uv_maps):
    """Base Color, Roughness, Metallic: an Image Texture's entry where one drives the socket (else
    its value; texture_export warns about other nodes there); Normal: a tangent-space Normal Map."""
    for key, name in (("base_color", "Base Color"), ("roughness", "Roughness"), ("metallic", "Metallic")):
        found = texture_export.socket_texture(node, name, warnings, what)
        if found is not None:
            p[key], uv = found
            uv_maps.append(uv)
        else:
            v = node.inputs[name].default_value
            p[key] = _rgb(v) if key == "base_color" else float(v)
    found = texture_export.normal_map(node, warnings, what)
    if found is not None:
        p["normal_map"], uv = found
        uv_maps.append(uv)


def principled_params(node, model, warnings, what, uv_maps=None):
    """The engine parameters of a Principled BSDF node under `model` (its Blender's); the UV maps its
    textures read are appended to uv_maps."""
    p = {"shader": _principled_shader(node)}
    _textured_inputs(node, p, warnings, what, [] if uv_maps is None else uv_maps)
    if model == "principled-v2":
        tint = _socket_value(node, "Specular Tint", warnings, what)
        p.update({"ior": _optional_float(node, "IOR", 1.5, warnings, what),
                  "specular_ior_level": _optional_float(node, "Specular IOR Level", 0.5, warnings, what),
                  "specular_tint_color": [1.0, 1.0, 1.0] if tint is None else _rgb(tint),
                  "diffuse_roughness": _optional_float(node, "Diffuse Roughness", 0.0, warnings, what),
                  "emission": _emission(node, "Emission Color", warnings, what)})
    else:
        p.update({"specular": _optional_float(node, "Specular", 0.5, warnings, what),
                  "specular_tint": _optional_float(node, "Specular Tint", 0.0, warnings, what),
                  "emission": _emission(node, "Emission", warnings, what)})
    _unrendered(node, model, warnings, what)
    return p


def output_surface_node(tree):
    """The node feeding the active (Cycles or All) Material Output's Surface, or None."""
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"]
    if not outputs:
        return None
    active = [n for n in outputs if n.is_active_output and n.target in ("ALL", "CYCLES")]
    out = (active or [n for n in outputs if n.target in ("ALL", "CYCLES")] or outputs)[0]
    sock = out.inputs.get("Surface")
    if sock is None or not sock.is_linked:
        return None
    return sock.links[0].from_node


def _constants(p, warnings, what):
    """Shader parameters with textures replaced by a constant (a mix of parameters cannot hold an image)."""
    if p is None:
        return None
    for key, default in (("base_color", [0.8, 0.8, 0.8]), ("roughness", 0.5), ("metallic", 0.0)):
        if texture_export.is_texture(p.get(key)):
            warnings.append("%s: the image on %s is inside a Mix/Add Shader; the engine mixes constants there "
                            "(%r used)" % (what, key, default))
            p[key] = default
    if p.pop("normal_map", None) is not None:
        warnings.append("%s: a normal map inside a Mix/Add Shader is not rendered" % what)
    return p


def _mix(parts, weights, add, model):
    """The weighted mix of shader parameters (Mix Shader: by Fac; Add Shader: emission summed)."""
    present = [(w, p) for w, p in zip(weights, parts) if p is not None]
    if not present:
        return None
    total = sum(w for w, _ in present)
    norm = [(w / total if total > 0 else 1.0 / len(present), p) for w, p in present]
    defaults = {**COMMON, **model_fields(model)}
    out = {}
    for key, d in defaults.items():
        if key in ("shader", "emission"):
            continue
        if isinstance(d, list):
            out[key] = [sum(w * p.get(key, d)[i] for w, p in norm) for i in range(3)]
        else:
            out[key] = sum(w * p.get(key, d) for w, p in norm)
    shaders = {p.get("shader", "principled") for _, p in norm}
    out["shader"] = shaders.pop() if len(shaders) == 1 else "principled"
    if add:
        out["emission"] = [sum(p["emission"][i] for _, p in present) for i in range(3)]
    else:
        out["emission"] = [sum(w * p["emission"][i] for w, p in zip(weights, parts) if p is not None)
                           for i in range(3)]
    return out


def shader_params(node, model, warnings, what, depth=0, uv_maps=None):
    """Parameters of the shader graph rooted at node, or None when it is not understood."""
    if node is None or depth > 16:
        return None
    t = node.type
    if t == "REROUTE":
        sock = node.inputs[0]
        return shader_params(sock.links[0].from_node if sock.is_linked else None, model, warnings, what, depth + 1,
                             uv_maps)
    if t == "BSDF_PRINCIPLED":
        return principled_params(node, model, warnings, what, uv_maps)
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
        parts = [_constants(shader_params(s.links[0].from_node, model, warnings, what, depth + 1), warnings, what)
                 if s.is_linked else None for s in shader_inputs[:2]]
        if t == "MIX_SHADER":
            fac = _clamp01(_socket_value(node, "Fac", warnings, what))
            weights = [1.0 - fac, fac]
        else:
            weights = [1.0, 1.0]
        out = _mix(parts, weights, t == "ADD_SHADER", model)
        if out is not None:
            warnings.append("%s: %s approximated by mixing its shaders' parameters" % (what, node.name))
        return out
    return None


def _finish(p, model, warnings, what):
    """Fills the model's defaults and clamps to the ranges Blender's nodes allow."""
    if not texture_export.is_texture(p["base_color"]):
        for i in range(3):
            if not 0.0 <= p["base_color"][i] <= 1.0:
                warnings.append("%s: base colour %r clamped to [0, 1]" % (what, p["base_color"]))
                p["base_color"] = [_clamp01(x) for x in p["base_color"]]
                break
    for key in ("roughness", "metallic"):
        if not texture_export.is_texture(p[key]):
            p[key] = _clamp01(p[key])
    for k, d in model_fields(model).items():
        p.setdefault(k, list(d) if isinstance(d, list) else d)
    if model == "principled-v2":
        p["ior"] = min(max(float(p["ior"]), 1.0), 1000.0)
        p["specular_ior_level"] = max(float(p["specular_ior_level"]), 0.0)
        p["specular_tint_color"] = [max(float(c), 0.0) for c in p["specular_tint_color"]]
        p["diffuse_roughness"] = _clamp01(p["diffuse_roughness"])
    else:
        p["specular"] = min(max(float(p["specular"]), 0.0), 12.0)
        p["specular_tint"] = _clamp01(p["specular_tint"])
    p.setdefault("shader", "principled")
    p["emission"] = [max(0.0, float(x)) for x in p.get("emission", [0.0, 0.0, 0.0])]
    return p


def material_params(material, warnings=None, model=None, uv_maps=None):
    """The engine material of a Blender material (None: the default material) under `model`
    (default: this Blender's, compat.principled_model()); the names of the UV maps its image
    textures read ("" = the mesh's default) are appended to uv_maps."""
    warnings = [] if warnings is None else warnings
    model = model or compat.principled_model()
    if material is None:
        return default_material(model)
    what = "material '%s'" % material.name
    p = None
    overridden = all(k in material for k in ("ptir_base_color", "ptir_roughness", "ptir_metallic"))
    if overridden:
        p = {"base_color": _rgb(material["ptir_base_color"]), "roughness": 0.5, "metallic": 0.0,
             "emission": [0.0, 0.0, 0.0]}
    elif compat.uses_nodes(material):
        p = shader_params(output_surface_node(material.node_tree), model, warnings, what, uv_maps=uv_maps)
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
    p = _finish(p, model, warnings, what)
    p["name"] = material.name
    return p
