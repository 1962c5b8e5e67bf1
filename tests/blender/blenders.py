"""The three Blenders the tests run scripts in (pytest side; no bpy):

    "3.4"  Debian's Blender ($BLENDER, default `blender`):
           blender -b --factory-startup -noaudio --python-exit-code 1 [FILE.blend] -P SCRIPT -- ARGS
    "4.5"  PyPI's bpy 4.5 LTS, "5.0": bpy 5.0 (headless Python modules in the venvs that
           scripts/setup_bpy.sh makes; `setup_bpy.sh --print` names their interpreters):
           VENV/bin/python bpy_run.py [--blend FILE.blend] SCRIPT -- ARGS
           (bpy_run.py: factory settings, the script as __main__ with the same argv after `--`,
           exit status 1 on an uncaught exception, as --python-exit-code 1 gives)

A test names the versions it needs:

    @pytest.mark.parametrize("blender", blenders.params())            # all three
    @pytest.mark.parametrize("blender", blenders.params("4.5", "5.0"))
    def test_x(blender, tmp_path):
        r = ac.run_blender("x_check.py", tmp_path, blender=blender)

A version that is not installed is skipped with the reason (`make test` installs all three).
command(version, ...) builds the command line; PTIR_BLENDERS="3.4,4.5" narrows params() to those.
"""

import functools
import os
import shutil
import subprocess
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
BLENDERS = ("3.4", "4.5", "5.0")
MODULE_VERSIONS = ("4.5", "5.0")  # the bpy modules: no UI, no viewport
BLENDER_34 = os.environ.get("BLENDER", "blender")
RUNNER = HERE / "bpy_run.py"


@functools.lru_cache(maxsize=None)
def bpy_pythons():
    """{"4.5": venv python, "5.0": ...} of the bpy venvs that exist (scripts/setup_bpy.sh --print)."""
    try:
        out = subprocess.run([str(REPO / "scripts" / "setup_bpy.sh"), "--print"], capture_output=True, text=True,
                             timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        return {}
    found = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 2 and os.access(parts[1], os.X_OK):
            found[".".join(parts[0].split(".")[:2])] = parts[1]
    return found


def available(version):
    if version == "3.4":
        return shutil.which(BLENDER_34) is not None
    if version in MODULE_VERSIONS:
        return version in bpy_pythons()
    raise ValueError("unknown Blender %r (one of %s)" % (version, ", ".join(BLENDERS)))


def why_missing(version):
    if version == "3.4":
        return "Blender 3.4 (%s) is not installed (scripts/setup_debian.sh)" % BLENDER_34
    return "bpy %s is not installed (run scripts/setup_bpy.sh)" % version


def command(version, script, args=(), blend=None):
    """The command line that runs `script` (a path) in that Blender with `-- args`, after opening blend."""
    args = [str(a) for a in args]
    if version == "3.4":
        cmd = [BLENDER_34, "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1"]
        if blend:
            cmd.append(str(blend))
        return cmd + ["-P", str(script), "--", *args]
    if version not in MODULE_VERSIONS:
        raise ValueError("unknown Blender %r (one of %s)" % (version, ", ".join(BLENDERS)))
    python = bpy_pythons().get(version)
    if python is None:
        raise RuntimeError(why_missing(version))
    cmd = [python, str(RUNNER)]
    if blend:
        cmd += ["--blend", str(blend)]
    return cmd + [str(script), "--", *args]


@functools.lru_cache(maxsize=None)
def engine_has_v2():
    """Whether the CLI in the build folder renders Cycles' Principled v2 (`ptir render --help` lists
    "principled-v2"): scenes the add-on exports in 4.x / 5.x name that model."""
    build = Path(os.environ.get("PTIR_BUILD_DIR", REPO / "build")).resolve()
    try:
        r = subprocess.run([str(build / "bin" / "ptir"), "render", "--help"], capture_output=True, text=True,
                           timeout=60)
    except (OSError, subprocess.SubprocessError):
        return False
    return "principled-v2" in (r.stdout + r.stderr)


V2_ENGINE = "the engine has no principled-v2 model yet (`ptir render --help`): Blender 4.x/5.x scenes name it"


def v2_needs():
    """params(needs=...) for tests that render scenes exported by Blender 4.5 / 5.0 with the engine."""
    return {v: (engine_has_v2, V2_ENGINE) for v in MODULE_VERSIONS}


def selected():
    """The versions params() offers: all three, or those $PTIR_BLENDERS lists (comma-separated)."""
    env = os.environ.get("PTIR_BLENDERS", "").strip()
    if not env:
        return BLENDERS
    wanted = tuple(v.strip() for v in env.split(",") if v.strip())
    unknown = [v for v in wanted if v not in BLENDERS]
    if unknown:
        raise ValueError("PTIR_BLENDERS names unknown Blenders %s (known: %s)" % (unknown, ", ".join(BLENDERS)))
    return wanted


def params(*versions, needs=None):
    """pytest params (ids "3.4", "4.5", "5.0") of the versions given (default: all three), each skipped
    when not installed. needs: {version: (condition, reason)}: that version is also skipped with the
    reason unless the condition (a bool or a callable, evaluated here) holds."""
    out = []
    for v in versions or BLENDERS:
        if v not in BLENDERS:
            raise ValueError("unknown Blender %r (one of %s)" % (v, ", ".join(BLENDERS)))
        marks = []
        if v not in selected():
            marks.append(pytest.mark.skip(reason="PTIR_BLENDERS leaves out Blender %s" % v))
        elif not available(v):
            marks.append(pytest.mark.skip(reason=why_missing(v)))
        elif needs and v in needs:
            cond, reason = needs[v]
            if not (cond() if callable(cond) else cond):
                marks.append(pytest.mark.skip(reason=reason))
        out.append(pytest.param(v, id=v, marks=marks))
    return out
