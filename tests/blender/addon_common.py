"""Shared helpers of the add-on tests (pytest side and Blender side; numpy only, no bpy).

- paths: the repository, the build folder ($PTIR_BUILD_DIR or <repo>/build), the CLI and module
- run_blender(script, *args, blender="3.4"): the script in one of the three Blenders (blenders.py) with the
  add-on taken from the repository and the CLI from the build folder ($PTIR_CLI): the CompletedProcess
- blender_result(script, marker, *args): run_blender, then the JSON of the script's `marker: {...}` line
- small PLY writers: a standard 3DGS PLY with chosen activated values, in any encoding
"""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("PTIR_BUILD_DIR", REPO / "build")).resolve()
CLI = BUILD / "bin" / "ptir"
MODULE_DIR = BUILD / "python"
ADDON_PARENT = REPO / "addon"
HERE = Path(__file__).resolve().parent
BLENDER = os.environ.get("BLENDER", "blender")
SH_C0 = 0.28209479177387814

sys.path.insert(0, str(ADDON_PARENT))
sys.path.insert(0, str(REPO / "scripts"))  # blender_kit: the shared Blender/scene helpers


def have_blender():
    return shutil.which(BLENDER) is not None


def run_blender(script, *args, blend=None, timeout=600, env_extra=None, blender="3.4"):
    """Runs HERE/script in one of the three Blenders (blenders.py: "3.4" blender -b with factory
    settings, "4.5" / "5.0" the bpy modules) with `-- args`; the add-on comes from the repository
    (addon_blender_harness.py enables it) and the CLI from the build folder."""
    import blenders  # (pytest side only: the Blender-side scripts import this file too)
    env = dict(os.environ)
    env["PTIR_CLI"] = str(CLI)
    env["PTIR_TEST_REPO"] = str(REPO)
    env["PTIR_TEST_MODULE_DIR"] = str(MODULE_DIR)
    env.update(env_extra or {})
    cmd = blenders.command(blender, HERE / script, args, blend=blend)
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)


def blender_result(script, marker, *args, timeout=600, blender="3.4", with_output=False):
    """Runs HERE/script with run_blender and returns the JSON of the last stdout line `marker: {...}`
    (with_output: and Blender's stdout + stderr); fails the calling test, with the end of Blender's
    output, when Blender fails or prints no such line."""
    proc = run_blender(script, *args, timeout=timeout, blender=blender)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, "Blender %s failed:\n%s" % (blender, out[-4000:])
    lines = [l for l in proc.stdout.splitlines() if l.startswith(marker + ": ")]
    assert lines, "no result line from Blender %s:\n%s" % (blender, out[-4000:])
    result = json.loads(lines[-1].split(": ", 1)[1])
    return (result, out) if with_output else result


def output_of(result):
    return "STDOUT:\n%s\nSTDERR:\n%s" % (result.stdout[-6000:], result.stderr[-4000:])


def inria_names(sh_rest=45, material=False, normals=True):
    names = ["x", "y", "z"] + (["nx", "ny", "nz"] if normals else []) + ["f_dc_0", "f_dc_1", "f_dc_2"]
    names += ["f_rest_%d" % i for i in range(sh_rest)]
    names += ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    if material:
        names += ["albedo_0", "albedo_1", "albedo_2", "roughness", "metallic"]
    return names


def random_raw(n, sh_rest=45, material=False, normals=True, seed=0):
    """Random raw (file) values of n splats: {name: float64 array}."""
    rng = np.random.default_rng(seed)
    raw = {}
    for k, c in enumerate("xyz"):
        raw[c] = rng.normal(size=n) * 2.0
    if normals:
        nrm = rng.normal(size=(n, 3))
        for k, c in enumerate(("nx", "ny", "nz")):
            raw[c] = nrm[:, k]
    for k in range(3):
        raw["f_dc_%d" % k] = rng.normal(size=n)
        raw["scale_%d" % k] = rng.uniform(-7.0, 1.0, size=n)
    for i in range(sh_rest):
        raw["f_rest_%d" % i] = rng.normal(size=n) * 0.2
    raw["opacity"] = rng.normal(size=n) * 3.0
    q = rng.normal(size=(n, 4))
    for k in range(4):
        raw["rot_%d" % k] = q[:, k] * rng.uniform(0.2, 3.0, size=n)  # unnormalised, as trainers store them
    if material:
        a = rng.uniform(0.0, 1.0, size=(n, 3))
        for k in range(3):
            raw["albedo_%d" % k] = a[:, k]
        raw["roughness"] = rng.uniform(0.05, 1.0, size=n)
        raw["metallic"] = rng.uniform(0.0, 1.0, size=n)
    return raw


def write_ply(path, raw, names=None, fmt="binary_little_endian", types=None, extra_elements=""):
    """Writes raw values as a PLY 'vertex' element: names in order (default: raw's order), format
    ascii / binary_little_endian / binary_big_endian, types {name: 'float'|'double'|'uchar'|...}."""
    names = list(raw) if names is None else list(names)
    n = len(raw[names[0]])
    types = types or {}
    np_types = {"float": "f4", "double": "f8", "uchar": "u1", "char": "i1", "short": "i2", "ushort": "u2",
                "int": "i4", "uint": "u4"}
    header = "ply\nformat %s 1.0\ncomment test file\nelement vertex %d\n" % (fmt, n)
    header += "".join("property %s %s\n" % (types.get(nm, "float"), nm) for nm in names)
    header += extra_elements + "end_header\n"
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        if fmt == "ascii":
            cols = [np.asarray(raw[nm]) for nm in names]
            lines = []
            for i in range(n):
                lines.append(" ".join(repr(float(np.float32(c[i]))) if types.get(nm, "float") in ("float",)
                                      else (repr(float(c[i])) if types.get(nm) == "double" else str(int(c[i])))
                                      for nm, c in zip(names, cols)))
            f.write(("\n".join(lines) + "\n").encode("ascii"))
        else:
            e = "<" if fmt == "binary_little_endian" else ">"
            rec = np.empty(n, dtype=[(nm, e + np_types[types.get(nm, "float")]) for nm in names])
            for nm in names:
                rec[nm] = raw[nm]
            f.write(rec.tobytes())
    return Path(path)


def activated_reference(raw):
    """Activated values computed independently: exp and normalisation in float64 rounded once to float32;
    opacity with the engine's float32 sigmoid formula."""
    pos = np.stack([np.float32(raw[c]).astype(np.float64) for c in "xyz"], axis=1).astype(np.float32)
    s = np.stack([np.exp(np.float32(raw["scale_%d" % k]).astype(np.float64)) for k in range(3)], axis=1)
    q = np.stack([np.float32(raw["rot_%d" % k]).astype(np.float64) for k in range(4)], axis=1)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    # the engine's formula, float32 1 / (1 + e) with e = exp(-x) rounded to float32
    e = np.exp(-np.float32(raw["opacity"]).astype(np.float64)).astype(np.float32)
    op = np.float32(1.0) / (np.float32(1.0) + e)
    return {"position": pos, "scale": s.astype(np.float32), "rotation": q.astype(np.float32), "opacity": op}


def ulps(a, b):
    """Distance in float32 units in the last place, element-wise."""
    a = np.asarray(a, np.float32).view(np.int32).astype(np.int64)
    b = np.asarray(b, np.float32).view(np.int32).astype(np.int64)
    a = np.where(a < 0, np.int64(-2**31) - a, a)
    b = np.where(b < 0, np.int64(-2**31) - b, b)
    return np.abs(a - b)


