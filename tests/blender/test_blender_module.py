"""The native module and the add-on inside Blender's own Python (blender -b; the native module also in
bpy 4.5 and 5.0, whose CPython 3.11 is the one it is built for)."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

import blenders

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("PTIR_BUILD_DIR", REPO / "build")).resolve()
BLENDER = [os.environ.get("BLENDER", "blender"), "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1"]

pytestmark = pytest.mark.skipif(shutil.which(BLENDER[0]) is None, reason="blender not installed")


def blender(*args):
    return subprocess.run([*BLENDER, *args], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("version", blenders.params())
def test_module_renders_inside_blender(version, tmp_path):
    module_dir = BUILD / "python"
    assert any(module_dir.glob("ptir*.so")), f"no native module in {module_dir} (run 'make build')"
    r = subprocess.run(blenders.command(version, Path(__file__).with_name("blender_render_check.py"),
                                        [module_dir, tmp_path]), capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "blender_render_check: OK" in r.stdout


@pytest.mark.parametrize("version", blenders.params())
def test_render_check_fails_loudly(version, tmp_path):
    """A broken check must fail the test: a module folder without ptir makes Blender exit 1."""
    r = subprocess.run(blenders.command(version, Path(__file__).with_name("blender_render_check.py"),
                                        [tmp_path, tmp_path]), capture_output=True, text=True, timeout=120)
    assert r.returncode == 1
    assert "FAILED" in r.stderr


def test_installed_addon_loads_native_module():
    """The add-on installed by scripts/install_addon.sh registers and finds its native module."""
    expr = ("import addon_utils, sys\n"
            "mod = addon_utils.enable('ptir_blender', default_set=False, handle_error=None)\n"
            "if mod is None: print('ADDON=missing'); sys.exit(3)\n"
            "print('ADDON=' + mod.bl_info['name'] + ' ' + mod.native().__file__)\n"
            "addon_utils.disable('ptir_blender')\n")
    r = blender("--python-expr", expr)
    if r.returncode == 3:
        pytest.skip("add-on not installed (run scripts/install_addon.sh)")
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    line = next(l for l in r.stdout.splitlines() if l.startswith("ADDON="))
    assert line.startswith("ADDON=PTIR ") and "ptir_blender" in line and line.endswith(".so")
