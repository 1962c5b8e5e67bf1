"""What differs between the Blenders the add-on runs in (3.4, 4.x LTS, 5.x), in one place.

- principled_model(): the engine's surface model matching this Blender's Principled BSDF:
  "principled-v1" (3.x, docs/PRINCIPLED.md) or "principled-v2" (4.0+, Blender's rewritten node)
- scene_brdf(): what the scene file's "brdf" records for that model
- PRINCIPLED_SOCKETS: the Principled BSDF's socket names of this Blender (renamed in 4.0)
- uses_nodes(id) / ensure_nodes(id): materials and worlds with node trees; 5.0 deprecates
  Material/World.use_nodes (always on, to be removed in 6.0), so it is read or set only before 5.0
- EEVEE_ENGINES: the EEVEE engine names ("BLENDER_EEVEE" in 3.x and 5.x, "BLENDER_EEVEE_NEXT" in 4.2-4.5)
"""

import bpy

VERSION = tuple(bpy.app.version)
V2 = VERSION >= (4, 0, 0)


def principled_model(version=None):
    """The engine model of this Blender's Principled BSDF (version: a (major, minor, patch) to ask for another)."""
    return "principled-v2" if tuple(version or VERSION) >= (4, 0, 0) else "principled-v1"


def scene_brdf(version=None):
    """The scene file's "brdf" for this Blender: "principled-v2" on 4.0+, "principled-v1" on 3.x
    (a scene file without "brdf" renders principled-v2)."""
    return principled_model(version)


# Principled BSDF sockets by role (PRINCIPLED_V2.md section 11: the v1 -> v2 renames).
_SOCKETS_V1 = {"base_color": "Base Color", "metallic": "Metallic", "roughness": "Roughness", "ior": "IOR",
               "specular": "Specular", "specular_tint": "Specular Tint", "emission": "Emission",
               "emission_strength": "Emission Strength", "transmission": "Transmission",
               "subsurface": "Subsurface", "coat": "Clearcoat", "sheen": "Sheen", "alpha": "Alpha"}
_SOCKETS_V2 = {"base_color": "Base Color", "metallic": "Metallic", "roughness": "Roughness", "ior": "IOR",
               "specular_ior_level": "Specular IOR Level", "specular_tint_color": "Specular Tint",
               "diffuse_roughness": "Diffuse Roughness",  # 4.3+
               "emission": "Emission Color", "emission_strength": "Emission Strength",
               "transmission": "Transmission Weight", "subsurface": "Subsurface Weight", "coat": "Coat Weight",
               "sheen": "Sheen Weight", "alpha": "Alpha"}
PRINCIPLED_SOCKETS = _SOCKETS_V2 if V2 else _SOCKETS_V1

EEVEE_ENGINES = frozenset(("BLENDER_EEVEE", "BLENDER_EEVEE_NEXT"))
EEVEE_ENGINE = "BLENDER_EEVEE_NEXT" if (4, 2, 0) <= VERSION < (5, 0, 0) else "BLENDER_EEVEE"

_NODES_ALWAYS = VERSION >= (5, 0, 0)


def uses_nodes(idblock):
    """Whether a material or world is shaded by its node tree."""
    if _NODES_ALWAYS:
        return idblock.node_tree is not None
    return bool(idblock.use_nodes) and idblock.node_tree is not None


def ensure_nodes(idblock):
    """Makes a material or world shaded by its node tree (created by Blender when missing); returns the tree."""
    if not _NODES_ALWAYS or idblock.node_tree is None:
        if _NODES_ALWAYS:
            import warnings
            with warnings.catch_warnings():  # (5.x: only data made without a tree, which Blender no longer makes)
                warnings.simplefilter("ignore", DeprecationWarning)
                idblock.use_nodes = True
        else:
            idblock.use_nodes = True
    return idblock.node_tree
