#!/usr/bin/env python3
"""Fails when an engine file includes a header from a higher layer.

The layers come from native/CMakeLists.txt (PTIR_LAYERS, bottom up; folders
joined by "+" form one layer and may use each other). Every #include "..." of
every file under native/src/ptir/<folder>/ is resolved (relative to the file, then
to native/src) and must land in the file's own layer or one below it.

  check_layers.py --src native/src --layers "math;core;io;lights+material;..."
  check_layers.py --self-test   # proves a back-edge, an unknown folder and a
                                # relative upward include are each caught
"""
import argparse
import os
import re
import sys
import tempfile

INCLUDE = re.compile(r'^[ \t]*#[ \t]*include[ \t]*"([^"]+)"', re.MULTILINE)
SOURCE_EXT = (".h", ".hpp", ".cpp", ".cc", ".inl")


def layer_ranks(layers):
    """{folder: rank} from ["math", "core", "lights+material", ...]."""
    ranks = {}
    for rank, layer in enumerate(layers):
        for folder in layer.split("+"):
            ranks[folder] = rank
    return ranks


def folder_of(path, engine_root):
    """The engine folder holding `path` (None when outside native/src/ptir)."""
    rel = os.path.relpath(os.path.realpath(path), os.path.realpath(engine_root))
    if rel.startswith(".."):
        return None
    parts = rel.split(os.sep)
    return parts[0] if len(parts) > 1 else None


def resolve(include, including_file, src_root):
    """The file an #include "..." names, or None when it is not ours."""
    for base in (os.path.dirname(including_file), src_root):
        candidate = os.path.normpath(os.path.join(base, include))
        if os.path.exists(candidate):
            return candidate
    if include.startswith("ptir/"):
        return os.path.normpath(os.path.join(src_root, include))  # missing file: judge by its path
    return None


def check(src_root, layers):
    """Returns the list of problems (empty when the layering holds)."""
    engine_root = os.path.join(src_root, "ptir")
    ranks = layer_ranks(layers)
    problems = []
    for folder in sorted(os.listdir(engine_root)):
        if os.path.isdir(os.path.join(engine_root, folder)) and folder not in ranks:
            problems.append(f"native/src/ptir/{folder}/ is in no layer (add it to PTIR_LAYERS)")
    for dirpath, _, files in os.walk(engine_root):
        for name in sorted(files):
            if not name.endswith(SOURCE_EXT):
                continue
            path = os.path.join(dirpath, name)
            own = folder_of(path, engine_root)
            if own not in ranks:
                continue
            with open(path, encoding="utf-8", errors="replace") as f:
                text = f.read()
            for m in INCLUDE.finditer(text):
                line = text.count("\n", 0, m.start()) + 1
                target = resolve(m.group(1), path, src_root)
                if target is None:
                    continue
                other = folder_of(target, engine_root)
                where = f"{os.path.relpath(path, src_root)}:{line}"
                if other is None:
                    if os.path.realpath(target).startswith(os.path.realpath(engine_root) + os.sep):
                        problems.append(f'{where}: includes "{m.group(1)}" outside any layer folder')
                    continue
                if other not in ranks:
                    problems.append(f'{where}: includes "{m.group(1)}" from {other}/, which is in no layer')
                elif ranks[other] > ranks[own]:
                    problems.append(f'{where}: {own}/ (layer {ranks[own]}) includes "{m.group(1)}" from the higher '
                                    f'layer {other}/ (layer {ranks[other]}); layers bottom up: {" -> ".join(layers)}')
    return problems


def write(root, rel, text):
    path = os.path.join(root, rel)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write(text)


def self_test():
    """The checker must fail on each kind of back-edge and pass on a clean tree."""
    layers = ["math", "io", "lights+material", "scene"]
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        write(tmp, "ptir/math/vec.h", "#pragma once\n")
        write(tmp, "ptir/io/image.h", '#include "ptir/math/vec.h"\n#include <vector>\n')
        write(tmp, "ptir/lights/env.h", '#include "ptir/io/image.h"\n#include "ptir/material/brdf.h"\n')
        write(tmp, "ptir/material/brdf.h", '#include "ptir/lights/env.h"\n')  # same layer: allowed
        write(tmp, "ptir/scene/scene.h", '#include "ptir/lights/env.h"\n#include "camera.h"\n')
        write(tmp, "ptir/scene/camera.h", "#pragma once\n")
        clean = check(tmp, layers)
        if clean:
            failures.append(f"clean tree reported: {clean}")
        cases = {
            "absolute": ("ptir/io/dataset.cpp", '#include "ptir/scene/camera.h"\n'),
            "relative": ("ptir/io/dataset.cpp", '#include "../scene/camera.h"\n'),
            "unknown folder": ("ptir/io/x.cpp", '#include "ptir/extra/y.h"\n'),
        }
        for label, (rel, text) in cases.items():
            write(tmp, rel, text)
            found = check(tmp, layers)
            os.remove(os.path.join(tmp, rel))
            if not found:
                failures.append(f"{label} back-edge not caught")
    for f in failures:
        print("self-test FAILED:", f)
    if not failures:
        print("self-test passed: a clean tree passes; absolute, relative and unknown-folder back-edges fail")
    return 1 if failures else 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--src", help="native/src (holding ptir/<folder>/)")
    ap.add_argument("--layers", help='layers bottom up, ";"- or ","-separated, e.g. "math;core;io;lights+material"')
    ap.add_argument("--self-test", action="store_true")
    a = ap.parse_args()
    if a.self_test:
        return self_test()
    if not a.src or not a.layers:
        ap.error("--src and --layers are required")
    layers = [l for l in re.split(r"[;,]", a.layers) if l]
    problems = check(a.src, layers)
    for p in problems:
        print(p)
    if problems:
        print(f"{len(problems)} layering problem(s)")
        return 1
    print(f"layering holds: {' -> '.join(layers)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
