"""The release zip (`make package`) installed the way artists install it, in three real Blenders.

Blender 4.5 LTS and 5.0 (PyPI's bpy, scripts/setup_bpy.sh) install it as an Extension, Debian's
Blender 3.4 as a legacy add-on; each then renders a small scene with the PTIR engine
(package_check.py). Every Blender runs with its user folders (BLENDER_USER_* and HOME) in a
temporary folder, without PTIR_CLI, and with a PATH on which no `ptir` is found, so the engine it
renders with can only be the one the zip carries. The zip is the one `make package` made
($PTIR_PACKAGE_ZIP, which the Makefile sets, else dist/ptir-<CMake version>-linux-x64.zip); the
test fails (it does not skip) when it or a Blender is missing.

It fails when: the zip is missing or Blender's own validator rejects its manifest; a Blender does
not install or enable it; the add-on picks another CLI than its bundled one, or a preference does
not override it; the installed CLI loads a library from outside the zip (beyond glibc and GCC's
runtime); the render fails or is blank, flat, non-finite, or lights the black world.
"""

import json
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))
import make_package  # noqa: E402

CHECK = Path(__file__).with_name("package_check.py")
BLENDERS = (("3.4", "legacy"), ("4.5", "extension"), ("5.0", "extension"))


@pytest.fixture(scope="module")
def zip_path():
    path = Path(os.environ.get("PTIR_PACKAGE_ZIP")
                or ROOT / "dist" / ("ptir-%s-linux-x64.zip" % make_package.project_version()))
    if not path.is_file():
        pytest.fail("no release zip %s (run 'make package')" % path)
    return path


def bpy_python(version):
    """The venv python of PyPI's bpy <version>.x (scripts/setup_bpy.sh)."""
    out = subprocess.run([str(ROOT / "scripts" / "setup_bpy.sh"), "--print"], capture_output=True, text=True,
                         check=True).stdout
    for line in out.splitlines():
        v, python = line.split(" ", 1)
        if v.startswith(version + "."):
            return python
    pytest.fail("no bpy %s venv (run scripts/setup_bpy.sh)" % version)


def clean_env(tmp):
    """The environment of a Blender that can only find the zip's CLI, with its user folders in tmp."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("PTIR_CLI", "PTIR_BUILD_DIR", "LD_LIBRARY_PATH", "PYTHONPATH") and not k.startswith("BLENDER_")}
    dirs = [d for d in env.get("PATH", "/usr/bin:/bin").split(os.pathsep)
            if d and not os.access(os.path.join(d, "ptir"), os.X_OK)]
    env["PATH"] = os.pathsep.join(dirs)
    assert shutil.which("ptir", path=env["PATH"]) is None
    user = tmp / "user"
    env.update(HOME=str(tmp / "home"), BLENDER_USER_RESOURCES=str(user / "resources"),
               BLENDER_USER_CONFIG=str(user / "config"), BLENDER_USER_SCRIPTS=str(user / "scripts"),
               BLENDER_USER_EXTENSIONS=str(user / "extensions"))
    (tmp / "home").mkdir()
    return env


def test_zip_layout_and_manifest(zip_path):
    """One top folder (the legacy add-on's package) holding the manifest, the add-on, bin/ptir and lib/."""
    with zipfile.ZipFile(zip_path) as z:
        names = z.namelist()
        manifest = z.read("ptir_blender/blender_manifest.toml").decode()
    assert {n.split("/", 1)[0] for n in names} == {"ptir_blender"}
    for needed in ("ptir_blender/__init__.py", "ptir_blender/bin/ptir", "ptir_blender/lib/libOpenImageIO.so.2.4",
                   "ptir_blender/lib/libembree3.so.3", "ptir_blender/lib/libtbb.so.12"):
        assert needed in names, needed
    assert not [n for n in names if "__pycache__" in n or re.search(r"/ptir[^/]*\.cpython-.*\.so$", n)], \
        "caches or the in-process Python module in the zip"
    assert not [n for n in names if make_package.BASELINE.match(n.rsplit("/", 1)[-1])], "glibc/libstdc++ bundled"
    # OpenCV (and GDAL, which it brings) is dropped from OpenImageIO's dependencies (make_package.PRUNE).
    assert not [n for n in names if re.search(r"/lib(opencv_|gdal)", n)], "OpenCV or GDAL bundled"
    assert 'version = "%s"' % make_package.project_version() in manifest
    assert 'blender_version_min = "4.2.0"' in manifest and 'platforms = ["linux-x64"]' in manifest
    # Blender's own extension tool (from bpy 4.5) validates the manifest strictly.
    ext_tool = next(Path(bpy_python("4.5")).parents[1].glob("lib/python3.*/site-packages/bpy/*/scripts/"
                                                              "addons_core/bl_pkg/cli/blender_ext.py"))
    r = subprocess.run([bpy_python("4.5"), str(ext_tool), "validate", str(zip_path)], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


@pytest.mark.parametrize("version,mode", BLENDERS, ids=[v for v, _ in BLENDERS])
def test_install_and_render(zip_path, tmp_path, version, mode):
    env = clean_env(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    if version == "3.4":
        if shutil.which("blender") is None:
            pytest.fail("Debian's blender is not installed (run scripts/setup_debian.sh)")
        cmd = ["blender", "-b", "--factory-startup", "-noaudio", "-P", str(CHECK), "--", mode, str(zip_path), str(out)]
    else:
        cmd = [bpy_python(version), str(CHECK), mode, str(zip_path), str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600, cwd=str(tmp_path))
    log = r.stdout + r.stderr
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("PACKAGE_STATS: ")]
    assert r.returncode == 0 and lines, "Blender %s failed:\n%s" % (version, log[-4000:])
    s = json.loads(lines[-1][len("PACKAGE_STATS: "):])
    assert s["blender"].startswith(version), s["blender"]

    # Installed into the temporary user area, and the bundled CLI is the one used.
    folder = Path(s["folder"])
    assert tmp_path in folder.parents, "installed outside the temporary user folders: %s" % folder
    assert s["ptir_on_path"] is None and s["PTIR_CLI"] is None
    assert s["cli_picked"] == s["bundled"] == s["bundled_cli"] == str(folder / "bin" / "ptir")
    assert s["executable_after"], "the bundled CLI was not made executable"
    assert s["cli_with_preference"] == "/bin/true", "an explicit preference must override the bundled CLI"

    # The installed CLI loads its libraries from its own lib/ (ldd through the RUNPATH $ORIGIN/../lib).
    lib = (folder / "lib").resolve()
    deps = make_package.ldd(str(folder / "bin" / "ptir"), env={"PATH": "/usr/bin:/bin"})
    outside = {n: p for n, p in deps.items()
               if not make_package.BASELINE.match(n) and (p is None or Path(p).resolve().parent != lib)}
    assert not outside, "the installed CLI loads libraries from outside the add-on: %s" % outside

    # The image: finite; the lit ground and cube cover part of the frame, the black world the rest (its top).
    assert (s["width"], s["height"]) == (64, 48)
    assert s["finite"]
    assert 0.2 < s["lit_fraction"] < 0.8, s
    assert s["dark_fraction"] > 0.1, s
    assert s["top_mean"] < 1e-4, s
    assert s["max"] > 0.1 and s["mean"] > 0.01, s
