"""PTIR for Blender: relight captured 3D Gaussian splats with recovered materials.

The heavy lifting is the native engine. Long jobs (F12 renders, optimisation)
run its command-line tool `ptir` as a child process (io/cli.py), so a native
crash never takes Blender down; the Python module `ptir` (native(), loaded
lazily) is optional and only used by scripts and tests. scripts/install_addon.sh
copies both next to this file (ptir*.so and bin/ptir).

Layout:
    io/          pure Python + numpy, no bpy (unit-testable): splat PLY read/write, scene file,
                 mesh PLY, the CLI child-process runner
    blender/     Blender data <-> engine data (bpy): splat objects, scene export, write-back
    operators/   import/export, material editing, optimisation; the PTIR render engine
    ui/          panels and menu entries
    properties   PropertyGroups (scene.ptir_render / ptir_optimize / ptir_edit, object.ptir_splat,
                 material.ptir) and the add-on preferences
"""

from .io.native_module import native  # noqa: F401 (mod.native(): the native engine module, loaded lazily)

bl_info = {
    "name": "PTIR",
    "author": "PTIR contributors",
    "version": (0, 3, 0),
    "blender": (3, 4, 0),
    "location": "File > Import/Export > Gaussian Splats (.ply); Render Engine 'PTIR'; View3D > Sidebar > PTIR",
    "description": "Path-traced inverse rendering of 3D Gaussian splats: import/export splats, render them "
                   "with meshes and lights, recover and edit their materials",
    "category": "Import-Export",
}

try:  # the io/ package is usable from plain Python (tests); everything else needs Blender
    import bpy  # noqa: F401
except ImportError:  # pragma: no cover - outside Blender
    bpy = None

if bpy is not None:
    from . import properties
    from .operators import capture_ops, io_ops, material_ops, optimize_ops, render_engine
    from .ui import compat_panels, panels

    # Registered in order, unregistered in reverse (Blender convention).
    classes = (properties.classes + io_ops.classes + material_ops.classes + optimize_ops.classes + capture_ops.classes
               + render_engine.classes + panels.classes)
else:
    classes = ()


def _upgrade_file_data(*_):
    """Data of files saved by older versions brought up to date (the splat display's node group)."""
    from .blender import splat_display
    splat_display.upgrade_display()
    return None  # (also a one-shot timer)


if bpy is not None:
    _upgrade_file_data = bpy.app.handlers.persistent(_upgrade_file_data)


def register():
    import bpy
    bpy.app.handlers.load_post.append(_upgrade_file_data)
    bpy.app.timers.register(_upgrade_file_data, first_interval=0.0)  # the file open when the add-on is enabled
    for cls in classes:
        bpy.utils.register_class(cls)
    properties.register_pointers()
    bpy.types.TOPBAR_MT_file_import.append(io_ops.menu_import)
    bpy.types.TOPBAR_MT_file_export.append(io_ops.menu_export)
    compat_panels.register()


def unregister():
    import bpy
    compat_panels.unregister()
    from .blender import engine_sync
    engine_sync.shutdown()
    bpy.types.TOPBAR_MT_file_export.remove(io_ops.menu_export)
    bpy.types.TOPBAR_MT_file_import.remove(io_ops.menu_import)
    optimize_ops.stop_all_jobs()
    properties.unregister_pointers()
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
    if _upgrade_file_data in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_upgrade_file_data)
