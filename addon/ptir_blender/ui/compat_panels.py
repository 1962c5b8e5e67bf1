"""Blender's own Properties panels shown under the PTIR engine: those Cycles shows.

An artist switching from Cycles to PTIR keeps the panels Cycles shows (Blender 3.4 to 5.x):

1. Blender's built-in panels that Cycles shows (the Cycles add-on marks them with "CYCLES" in their
   COMPAT_ENGINES: camera, lens, output, format, colour management, object and mesh data, ...), except
   what the engine does not render (Freestyle, render passes and their view-layer filter, light groups,
   the shadow terminator). Without the Cycles add-on: the engine-neutral ones ("BLENDER_RENDER").
2. In place of Cycles' own panels for what the engine reads (CYCLES_MATERIAL_PT_surface,
   CYCLES_WORLD_PT_surface, CYCLES_LIGHT_PT_light, ...; their shared COMPAT_ENGINES set cannot take
   another engine without showing every Cycles panel), the EEVEE panels that draw the same: the
   material slots and surface, the world surface, the light (EEVEE_COUNTERPARTS). Their names are
   the same in 3.4, 4.x (engine BLENDER_EEVEE_NEXT in 4.2-4.5) and 5.x (BLENDER_EEVEE again).

Panel classes often share one COMPAT_ENGINES set object (inherited from a base class), so "PTIR" is
never added to a shared set: each chosen class gets its own copy with "PTIR", and unregister()
restores exactly what was there.
"""

import bpy

EEVEE_COUNTERPARTS = ("EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface", "EEVEE_WORLD_PT_surface",
                      "DATA_PT_EEVEE_light")
_NOT_RENDERED = ("freestyle", "VIEWLAYER_PT_filter", "VIEWLAYER_PT_layer_passes", "lightgroup", "light_group",
                 "OBJECT_PT_shadow_terminator", "_PT_lineart")
_OWN_PREFIXES = ("CYCLES_", "NODE_CYCLES_")
_MISSING = object()
_changed = []  # (class, the COMPAT_ENGINES in its own __dict__ before, or _MISSING)


def _panel_classes():
    for name in dir(bpy.types):
        cls = getattr(bpy.types, name, None)
        if isinstance(cls, type) and issubclass(cls, bpy.types.Panel) and isinstance(
                getattr(cls, "COMPAT_ENGINES", None), (set, frozenset)):
            yield name, cls


def wanted(name, engines, cycles_present):
    """Whether the panel `name` with these COMPAT_ENGINES shows under PTIR."""
    if any(part.lower() in name.lower() for part in _NOT_RENDERED):
        return False
    if name in EEVEE_COUNTERPARTS:
        return True
    if name.startswith(_OWN_PREFIXES):
        return False
    return "CYCLES" in engines if cycles_present else "BLENDER_RENDER" in engines


def register(engine="PTIR"):
    classes = list(_panel_classes())
    cycles_present = any("CYCLES" in cls.COMPAT_ENGINES for _, cls in classes)
    for name, cls in classes:
        engines = cls.COMPAT_ENGINES
        if engine in engines or not wanted(name, engines, cycles_present):
            continue
        _changed.append((cls, cls.__dict__.get("COMPAT_ENGINES", _MISSING)))
        cls.COMPAT_ENGINES = set(engines) | {engine}


def unregister():
    while _changed:
        cls, before = _changed.pop()
        if before is _MISSING:
            if "COMPAT_ENGINES" in cls.__dict__:
                delattr(cls, "COMPAT_ENGINES")
        else:
            cls.COMPAT_ENGINES = before
