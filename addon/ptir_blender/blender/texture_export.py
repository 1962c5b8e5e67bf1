"""Image textures on Principled inputs -> the scene file's texture entries (docs/scene_format.md).

    socket_texture(node, "Base Color", warnings, what)  # -> ({"texture", "colorspace", "interpolation"}, uv_map) or None
    normal_map(node, warnings, what)                    # -> ({"texture", ..., "strength"}, uv_map) or None

What the engine renders, as Cycles does: an Image Texture node (its Color output; Linear or Closest
interpolation; Repeat extension; flat projection) whose Vector input is unlinked (the default UV map),
a UV Map node or a Texture Coordinate node's UV output, linked to Base Color, Roughness or Metallic
(Reroutes between are fine); and a Normal Map node in tangent space, its Color from such an Image
Texture, linked to Normal. uv_map is the UV map's name ("" = the mesh's render-active one).

Anything else between the texture and the socket (a Mix, a ColorRamp, a Separate RGB, a Bump node,
...) cannot be rendered: a warning names the material, the socket and the node, and the socket's
own value is used. Images that are packed, generated or edited and unsaved are written to a
temporary file (an .exr of their pixels, or the packed file's bytes); the entry names the file by
its absolute path, so a scene file and a `ptir serve` request read the same.
"""

import hashlib
import os
import tempfile

import bpy

from . import image_files

# Blender colour spaces whose values the engine takes as stored (data).
DATA_SPACES = {"Non-Color", "Raw", "Linear", "Linear Rec.709", "Linear BT.709", "Utility - Raw",
               "Linear CIE-XYZ E", "Generic Data"}


def _source(sock):
    """(node, output socket) feeding an input socket, through Reroutes; (None, None) when unlinked."""
    if not sock.is_linked:
        return None, None
    link = sock.links[0]
    node, out = link.from_node, link.from_socket
    for _ in range(64):
        if node.type != "REROUTE":
            return node, out
        inp = node.inputs[0]
        if not inp.is_linked:
            return None, None
        node, out = inp.links[0].from_node, inp.links[0].from_socket
    return None, None


def texture_folder():
    """Where packed and unsaved images are written (one folder per Blender session)."""
    path = os.path.join(bpy.app.tempdir or tempfile.gettempdir(), "ptir_textures")
    os.makedirs(path, exist_ok=True)
    return path


def image_file(image, warnings, what):
    """The absolute path of a file holding the image's pixels as Blender renders them."""
    if image.packed_file is not None:
        data = bytes(image.packed_file.data)
        ext = os.path.splitext(image.filepath)[1] or ".png"
        path = os.path.join(texture_folder(), "packed_%s%s" % (hashlib.sha1(data).hexdigest()[:16], ext))
        if not os.path.exists(path):
            with open(path + ".part", "wb") as f:
                f.write(data)
            os.replace(path + ".part", path)
        return path
    if image.source == "FILE" and not image.is_dirty:
        path = bpy.path.abspath(image.filepath, library=image.library)
        return os.path.normpath(path)
    if image.source in ("FILE", "GENERATED"):
        # Generated or painted and unsaved: its pixels as stored (8-bit images: sRGB values, decoded by
        # the engine for an sRGB image), written losslessly.
        name = "image_%s" % hashlib.sha1(("%s|%d" % (image.name, id(image))).encode()).hexdigest()[:16]
        return image_files.save_image_exr(image, os.path.join(texture_folder(), name + ".exr"))
    warnings.append("%s: image '%s' is a %s; the engine reads still images only" % (what, image.name, image.source.lower()))
    return None


def _colorspace(image, warnings, what):
    name = image.colorspace_settings.name
    if name == "sRGB":
        return "srgb"
    if name in DATA_SPACES:
        return "non-color"
    warnings.append("%s: image '%s' has colour space '%s'; the engine reads sRGB and Non-Color only "
                    "(taken as %s)" % (what, image.name, name, "Non-Color" if image.is_float else "sRGB"))
    return "non-color" if image.is_float else "srgb"


def _uv_map(tex, warnings, what):
    """The UV map an Image Texture node reads ("" = the default), or None when it reads something else."""
    src, out = _source(tex.inputs["Vector"])
    if src is None:
        return ""
    if src.type == "UVMAP":
        return src.uv_map
    if src.type == "TEX_COORD" and out.name == "UV":
        return ""
    warnings.append("%s: texture coordinates of '%s' come from '%s' (%s); the engine reads UV maps only "
                    "(the default UV map is used)" % (what, tex.name, src.name, out.name))
    return ""


def image_texture(tex, out, warnings, what, target):
    """The entry of an Image Texture node feeding `target` (a socket's description), or None."""
    if out.name != "Color":
        warnings.append("%s: %s is driven by the '%s' output of '%s'; the engine reads its Color only "
                        "(the socket's value is used)" % (what, target, out.name, tex.name))
        return None
    image = tex.image
    if image is None:
        warnings.append("%s: '%s' has no image (the socket's value is used)" % (what, tex.name))
        return None
    if image.source == "TILED":
        warnings.append("%s: '%s' is a UDIM image; the engine reads its first tile's file only" % (what, tex.name))
    path = image_file(image, warnings, what)
    if path is None:
        return None
    interpolation = {"Linear": "linear", "Closest": "closest"}.get(tex.interpolation)
    if interpolation is None:
        warnings.append("%s: '%s' uses %s interpolation; the engine filters it as Linear"
                        % (what, tex.name, tex.interpolation))
        interpolation = "linear"
    if tex.extension != "REPEAT":
        warnings.append("%s: '%s' uses the %s extension; the engine repeats the image (Repeat)"
                        % (what, tex.name, tex.extension.title()))
    if tex.projection != "FLAT":
        warnings.append("%s: '%s' uses %s projection; the engine projects it Flat" % (what, tex.name, tex.projection.title()))
    entry = {"texture": path, "colorspace": _colorspace(image, warnings, what), "interpolation": interpolation}
    return entry, _uv_map(tex, warnings, what)


def socket_texture(node, name, warnings, what):
    """(entry, uv_map) of the Image Texture driving input `name` of node, or None (then a warning
    says what drives it, unless nothing does)."""
    sock = node.inputs.get(name)
    if sock is None or not sock.is_linked:
        return None
    src, out = _source(sock)
    if src is not None and src.type == "TEX_IMAGE":
        return image_texture(src, out, warnings, what, "'%s'" % name)
    warnings.append("%s: '%s' of %s is driven by '%s' (%s), which the engine cannot render; the socket's value "
                    "is used (an Image Texture linked straight to it is rendered)"
                    % (what, name, node.name, src.name if src else "?", src.bl_idname if src else "?"))
    return None


def normal_map(node, warnings, what):
    """(entry with "strength", uv_map) of a tangent-space Normal Map node driving the Normal input,
    or None (a warning names anything else linked there)."""
    sock = node.inputs.get("Normal")
    if sock is None or not sock.is_linked:
        return None
    src, _ = _source(sock)
    if src is None or src.type != "NORMAL_MAP":
        warnings.append("%s: 'Normal' of %s is driven by '%s' (%s), which the engine cannot render; the surface's "
                        "own normal is used (a Normal Map node in tangent space is rendered)"
                        % (what, node.name, src.name if src else "?", src.bl_idname if src else "?"))
        return None
    if src.space != "TANGENT":
        warnings.append("%s: '%s' is in %s space; the engine renders tangent space only (ignored)"
                        % (what, src.name, src.space.title()))
        return None
    strength = src.inputs["Strength"]
    if strength.is_linked:
        warnings.append("%s: Strength of '%s' is driven by a node; its value is used" % (what, src.name))
    colour = socket_texture(src, "Color", warnings, what)
    if colour is None:
        if not src.inputs["Color"].is_linked:
            warnings.append("%s: '%s' has no image on Color (a flat normal; ignored)" % (what, src.name))
        return None
    entry, tex_uv = colour
    entry["strength"] = max(0.0, float(strength.default_value))
    if src.uv_map and tex_uv and src.uv_map != tex_uv:
        warnings.append("%s: '%s' takes tangents of UV map '%s' but its image reads '%s'; the engine uses '%s'"
                        % (what, src.name, src.uv_map, tex_uv, tex_uv))
    return entry, tex_uv or src.uv_map


def is_texture(value):
    """Whether a material field is a texture entry (not a constant)."""
    return isinstance(value, dict)


def uses_textures(params):
    """Whether engine material params read any texture (the mesh then needs UVs, and tangents for a normal map)."""
    return any(is_texture(v) for v in params.values())
