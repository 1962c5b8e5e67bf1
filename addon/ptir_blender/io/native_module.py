"""The native engine module `ptir` shipped inside the add-on, loaded lazily (no bpy).

Optional: the add-on runs the engine as a child process; the module serves scripts, tests and
the exact EXR writes of image_files.py.
"""

import os
import sys

_ADDON_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


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
