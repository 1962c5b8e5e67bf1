"""PTIR for Blender: relight captured 3D Gaussian splats with recovered materials.

The heavy lifting is the native engine (`ptir`, a pybind11 module built by the
project's CMake and copied next to this file by scripts/install_addon.sh).
Operators and panels register through `classes`; they are added as they land.
"""

import os
import sys

bl_info = {
    "name": "PTIR",
    "author": "PTIR contributors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "description": "Path-traced inverse rendering of 3D Gaussian splats",
    "category": "Import-Export",
}

# Registered in order, unregistered in reverse (Blender convention).
classes = ()

_ADDON_DIR = os.path.dirname(os.path.abspath(__file__))


def native():
    """Returns the native engine module `ptir` shipped inside this add-on.

    Imported lazily so the add-on still registers (and can report the problem)
    when the module is missing or was built for another Python.
    """
    if _ADDON_DIR not in sys.path:
        sys.path.insert(0, _ADDON_DIR)
    try:
        import ptir
    except ImportError as e:
        here = "%d.%d" % sys.version_info[:2]
        built = sorted(f for f in os.listdir(_ADDON_DIR) if f.startswith("ptir") and f.endswith(".so"))
        hint = ("found %s" % ", ".join(built)) if built else "no ptir*.so in %s" % _ADDON_DIR
        raise ImportError(
            "PTIR: cannot load the native module 'ptir' (%s). Blender runs Python %s; the module "
            "must be built for exactly that version (ptir.cpython-%s-*.so): rebuild with "
            "-DPython_EXECUTABLE=/usr/bin/python%s and run scripts/install_addon.sh. Cause: %s"
            % (hint, here, here.replace(".", ""), here, e)) from e
    return ptir


def register():
    import bpy
    for cls in classes:
        bpy.utils.register_class(cls)


def unregister():
    import bpy
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
