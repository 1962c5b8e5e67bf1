"""Blender side of the add-on tests: enable the add-on from the repository and run a check.

    import addon_blender_harness as h
    h.enable_addon()
    h.run(main)          # prints "ADDON_CHECK: OK", or the traceback and exits 1

`blender -b` exits 0 after an uncaught exception in a -P script unless
--python-exit-code is given; run() exits 1 explicitly either way.
"""

import os
import sys
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.environ.get("PTIR_TEST_REPO") or os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(REPO, "addon"))
sys.path.insert(0, os.path.join(REPO, "scripts"))  # blender_kit: the shared Blender helpers


def gui_fail(msg):
    """Ends a GUI (timer-driven) check at once: exceptions in timers do not stop Blender."""
    sys.stderr.write("ADDON_CHECK: FAILED: %s\n" % msg)
    sys.stderr.flush()
    os._exit(1)


def window_and_view3d():
    """The first window and its 3D viewport area."""
    import bpy
    win = bpy.context.window_manager.windows[0]
    return win, next(a for a in win.screen.areas if a.type == "VIEW_3D")


def argv():
    return sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


def enable_addon():
    """Enables ptir_blender from <repo>/addon (not an installed copy) with its preferences."""
    import addon_utils
    import bpy
    for name in [m for m in sys.modules if m == "ptir_blender" or m.startswith("ptir_blender.")]:
        mod = sys.modules[name]
        if not os.path.abspath(getattr(mod, "__file__", "") or "").startswith(os.path.join(REPO, "addon")):
            del sys.modules[name]
    mod = addon_utils.enable("ptir_blender", default_set=True, handle_error=None)
    if mod is None:
        raise RuntimeError("could not enable ptir_blender from %s" % os.path.join(REPO, "addon"))
    where = os.path.dirname(os.path.abspath(mod.__file__))
    if not where.startswith(os.path.join(REPO, "addon")):
        raise RuntimeError("enabled ptir_blender from %s, not from the repository" % where)
    assert bpy.context.preferences.addons.get("ptir_blender") is not None
    return mod


def native_module():
    """The native module from the build folder (PTIR_TEST_MODULE_DIR), or None."""
    d = os.environ.get("PTIR_TEST_MODULE_DIR")
    if d and d not in sys.path:
        sys.path.insert(0, d)
    try:
        import ptir
        return ptir
    except ImportError:
        return None


def check(cond, what):
    if not cond:
        raise AssertionError(what)


def spec_scene_with_splats():
    """The checks driven by a SPEC.json (argv: SPEC.json WORK_DIR): an empty scene with the spec's
    "input" splat PLY imported. Returns (spec, work_dir, the splat object)."""
    import json

    import bpy
    spec_path, work = argv()[:2]
    spec = json.load(open(spec_path))
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=spec["input"])
    check(r == {"FINISHED"}, "import splats")
    return spec, work, bpy.context.active_object


def run(main):
    try:
        main()
    except SystemExit:
        raise
    except BaseException:
        traceback.print_exc()
        sys.stderr.write("ADDON_CHECK: FAILED\n")
        sys.stderr.flush()
        sys.exit(1)
    print("ADDON_CHECK: OK", flush=True)
