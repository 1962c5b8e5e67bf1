#!/usr/bin/env python3
"""Fails when an engine file includes a header from a higher layer.

The layers come from native/CMakeLists.txt (PTIR_LAYERS, bottom up; folders
joined by "+" form one layer and may use each other). Every #include "..." of
every file under native/src/ptir/<folder>/ is resolved (relative to the file, then
to native/src) and must land in the file's own layer or one below it.

  check_layers.py --src native/src --layers "math;core;io;lights+material;..."
  check_layers.py --self-test   # proves a back-edge, an unknown folder and a
                                # relative upward include are each caught

The add-on (--addon addon/ptir_blender) has layers too, bottom up: errors, io,
blender, properties + operators, ui, then the package itself. Every import of every
module (at module level or inside a function) must land in its own layer or one
below; io/ must not import Blender's modules (bpy, mathutils, gpu, bpy_extras:
it is plain Python, unit-testable without Blender); and the modules' imports must
form no circle.

  check_layers.py --addon addon/ptir_blender
"""
import argparse
import ast
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


def not_caught(root, cases, check_tree):
    """The labels of {label: (file, text)} whose file, written into the tree alone, check_tree(root) does not
    report (each case's file is put back as it was afterwards)."""
    missed = []
    for label, (rel, text) in cases.items():
        path = os.path.join(root, rel)
        old = open(path).read() if os.path.exists(path) else None
        write(root, rel, text)
        if not check_tree(root):
            missed.append(label)
        if old is None:
            os.remove(path)
        else:
            write(root, rel, old)
    return missed


def run_self_test(files, cases, check_tree, name, passed):
    """A clean tree of `files` must pass check_tree; each of `cases` added to it must fail it."""
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        for rel, text in files.items():
            write(tmp, rel, text)
        clean = check_tree(tmp)
        if clean:
            failures.append(f"clean tree reported: {clean}")
        failures += [f"{label} not caught" for label in not_caught(tmp, cases, check_tree)]
    for f in failures:
        print(f"{name} FAILED:", f)
    if not failures:
        print(passed)
    return 1 if failures else 0


def self_test():
    """The checker must fail on each kind of back-edge and pass on a clean tree."""
    layers = ["math", "io", "lights+material", "scene"]
    files = {
        "ptir/math/vec.h": "#pragma once\n",
        "ptir/io/image.h": '#include "ptir/math/vec.h"\n#include <vector>\n',
        "ptir/lights/env.h": '#include "ptir/io/image.h"\n#include "ptir/material/brdf.h"\n',
        "ptir/material/brdf.h": '#include "ptir/lights/env.h"\n',  # same layer: allowed
        "ptir/scene/scene.h": '#include "ptir/lights/env.h"\n#include "camera.h"\n',
        "ptir/scene/camera.h": "#pragma once\n",
    }
    cases = {
        "absolute back-edge": ("ptir/io/dataset.cpp", '#include "ptir/scene/camera.h"\n'),
        "relative back-edge": ("ptir/io/dataset.cpp", '#include "../scene/camera.h"\n'),
        "unknown-folder back-edge": ("ptir/io/x.cpp", '#include "ptir/extra/y.h"\n'),
    }
    return run_self_test(files, cases, lambda root: check(root, layers), "self-test",
                         "self-test passed: a clean tree passes; absolute, relative and unknown-folder back-edges fail")


# ------------------------------------------------------------------ the add-on

ADDON_LAYERS = ["errors", "io", "blender", "properties+operators", "ui", "__init__"]
BLENDER_MODULES = ("bpy", "mathutils", "gpu", "bpy_extras", "bl_math", "blf", "bmesh", "idprop")


def addon_modules(root):
    """{dotted name relative to the package ("io.cli", "__init__"): path} of every module of the add-on."""
    out = {}
    for dirpath, _, files in os.walk(root):
        for name in sorted(files):
            if not name.endswith(".py"):
                continue
            rel = os.path.relpath(os.path.join(dirpath, name), root)[:-3].replace(os.sep, ".")
            if rel.endswith(".__init__") and rel != "__init__":
                rel = rel[: -len(".__init__")]
            out[rel] = os.path.join(dirpath, name)
    return out


def module_imports(path, name, modules):
    """[(line, imported add-on module or None, top-level name of anything else)] of one module."""
    with open(path, encoding="utf-8") as f:
        tree = ast.parse(f.read(), path)
    package = name.split(".")[:-1] if name in modules and not os.path.basename(path) == "__init__.py" else \
        ([] if name == "__init__" else name.split("."))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                found.append((node.lineno, None, a.name.split(".")[0]))
        elif isinstance(node, ast.ImportFrom):
            if node.level == 0:
                found.append((node.lineno, None, (node.module or "").split(".")[0]))
                continue
            base = package[: len(package) - (node.level - 1)] if node.level > 1 else list(package)
            target = base + (node.module.split(".") if node.module else [])
            for a in node.names:
                full = ".".join(target + [a.name])
                mod = full if full in modules else ".".join(target)
                found.append((node.lineno, mod or "__init__", None))
    return found


def addon_layer(name):
    top = name.split(".")[0]
    return "__init__" if top == "__init__" else top


def check_addon(root):
    """Problems of the add-on's imports: a Blender module in io/, an arrow back up, a circle."""
    ranks = layer_ranks(ADDON_LAYERS)
    modules = addon_modules(root)
    problems = []
    graph = {m: set() for m in modules}
    for name, path in sorted(modules.items()):
        own = addon_layer(name)
        if own not in ranks:
            problems.append(f"{os.path.relpath(path, root)}: {own}/ is in no add-on layer (add it to ADDON_LAYERS)")
            continue
        for line, mod, other in module_imports(path, name, modules):
            where = f"{os.path.relpath(path, root)}:{line}"
            if mod is None:
                if own == "io" and other in BLENDER_MODULES:
                    problems.append(f"{where}: io/ imports {other} (io/ must run without Blender)")
                continue
            graph[name].add(mod)
            theirs = addon_layer(mod)
            if theirs in ranks and ranks[theirs] > ranks[own]:
                problems.append(f"{where}: {own} imports {mod} from the higher layer {theirs}; "
                                f"layers bottom up: {' -> '.join(ADDON_LAYERS)}")
    problems += [f"import circle: {' -> '.join(c)}" for c in circles(graph)]
    return problems


def circles(graph):
    """The import circles of a module graph (one per strongly connected set of modules, as a path)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            members = []
            while True:
                w = stack.pop()
                on.discard(w)
                members.append(w)
                if w == v:
                    break
            if len(members) > 1 or v in graph.get(v, ()):
                out.append(sorted(members) + [sorted(members)[0]])

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def addon_self_test():
    """The add-on check must fail on bpy in io/, an upward import and a circle, and pass a clean tree."""
    package = "from .operators import ops\n"
    files = {"__init__.py": package, "errors.py": "class E(Exception): pass\n",
             "io/__init__.py": "", "io/cli.py": "import os\nfrom ..errors import E\n",
             "blender/__init__.py": "", "blender/a.py": "import bpy\nfrom ..io import cli\nfrom . import b\n",
             "blender/b.py": "import bpy\n", "operators/__init__.py": "", "operators/ops.py": "from ..blender import a\n"}
    cases = {"bpy in io/": ("io/x.py", "def f():\n    import bpy.types\n"),
             "arrow back up": ("io/y.py", "from ..blender import a\n"),
             "circle": ("blender/b.py", "def f():\n    from .a import g\n")}
    return run_self_test(files, cases, check_addon, "add-on self-test",
                         "add-on self-test passed: a clean add-on passes; bpy in io/, an upward import and a circle fail")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--src", help="native/src (holding ptir/<folder>/)")
    ap.add_argument("--layers", help='layers bottom up, ";"- or ","-separated, e.g. "math;core;io;lights+material"')
    ap.add_argument("--addon", help="the add-on package folder (addon/ptir_blender): check its imports instead")
    ap.add_argument("--self-test", action="store_true")
    a = ap.parse_args()
    if a.self_test:
        return self_test() | addon_self_test()
    if a.addon:
        return report(check_addon(a.addon), "add-on import problem(s)",
                      f"add-on layering holds: {' -> '.join(ADDON_LAYERS)}; io/ imports no Blender module; "
                      "no import circle")
    if not a.src or not a.layers:
        ap.error("--src and --layers are required")
    layers = [l for l in re.split(r"[;,]", a.layers) if l]
    return report(check(a.src, layers), "layering problem(s)", f"layering holds: {' -> '.join(layers)}")


def report(problems, what, holds):
    """Prints the problems (and their count) or that the layering holds; the exit status."""
    for p in problems:
        print(p)
    if problems:
        print(f"{len(problems)} {what}")
        return 1
    print(holds)
    return 0

if __name__ == "__main__":
    sys.exit(main())
