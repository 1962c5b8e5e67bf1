"""Runs a Blender-side test script in PyPI's bpy module as `blender -b --factory-startup
--python-exit-code 1 [FILE.blend] -P SCRIPT -- ARGS` runs it in Blender 3.4:

    VENV/bin/python bpy_run.py [--blend FILE.blend] SCRIPT -- ARGS

- factory settings (no user preferences or add-ons), then FILE.blend opened when given;
- SCRIPT runs as __main__ with sys.argv ending in `-- ARGS` (the scripts read what follows `--`);
- exit status: the script's sys.exit code, 1 after an uncaught exception (its traceback printed),
  else 0. The process ends with os._exit after flushing: bpy 4.5's exit handlers can hang
  (a delayed-close thread waits forever in its static state's destructor).
"""

import os
import runpy
import sys
import traceback


def _exit(code):
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def main():
    args = sys.argv[1:]
    blend = None
    if args[:1] == ["--blend"]:
        blend, args = args[1], args[2:]
    if not args or args[0] == "--":
        sys.stderr.write("usage: bpy_run.py [--blend FILE.blend] SCRIPT -- ARGS\n")
        _exit(2)
    script, rest = args[0], args[1:]
    if rest[:1] != ["--"]:
        rest = ["--", *rest]
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=False)
    if blend:
        bpy.ops.wm.open_mainfile(filepath=os.path.abspath(blend))
    sys.argv = [sys.executable, script, *rest]
    code = 0
    try:
        runpy.run_path(script, run_name="__main__")
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
        if e.code is not None and not isinstance(e.code, int):
            sys.stderr.write("%s\n" % e.code)
    except BaseException:
        traceback.print_exc()
        code = 1
    _exit(code)


if __name__ == "__main__":
    main()
