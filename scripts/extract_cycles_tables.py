#!/usr/bin/env python3
"""Copies Cycles' own microfacet tables out of a PyPI `bpy` build (Blender 4.5 / 5.0).

    python3 scripts/extract_cycles_tables.py BPY_INIT_SO [BPY_INIT_SO ...] > tests/data/cycles_tables_4.5.txt

Cycles compiles intern/cycles/scene/shader.tables into the binary as static float arrays.
The script finds table_ggx_E by its first row (1.000000, 0.980405, 0.994967, 0.997749 --
the row printed in shader.tables) and reads the tables stored beside it: table_ggx_Eavg
(the 32 floats before it) and table_ggx_gen_schlick_ior_s / table_ggx_gen_schlick_s
(4096 floats each, 15904 and 20000 floats before it). Each table is accepted only if its
sum matches the sum of the table in Cycles' shader.tables (v5.1.2, recorded below) to
1e-4, and when several binaries are given they must hold identical bytes. Output: one
"# name count sum" line then the values, 6 decimals as in shader.tables, one table row per line.
"""
import struct
import sys

# (name, count, offset in floats from table_ggx_E, sum of the shader.tables values)
TABLES = [("ggx_E", 1024, 0, 849.736018), ("ggx_Eavg", 32, -32, 25.879163),
          ("ggx_gen_schlick_ior_s", 4096, -15904, 184.247126), ("ggx_gen_schlick_s", 4096, -20000, 764.768581)]
ROW = {"ggx_E": 32, "ggx_Eavg": 32, "ggx_gen_schlick_ior_s": 16, "ggx_gen_schlick_s": 16}
FIRST_ROW = struct.pack("<4f", 1.0, 0.980405, 0.994967, 0.997749)


def extract(path):
    data = open(path, "rb").read()
    at = data.find(FIRST_ROW)
    if at < 0:
        raise SystemExit(f"{path}: table_ggx_E not found (not a Cycles build?)")
    out = {}
    for name, count, offset, want in TABLES:
        start = at + 4 * offset
        values = struct.unpack(f"<{count}f", data[start:start + 4 * count])
        if abs(sum(values) - want) > 1e-4:
            raise SystemExit(f"{path}: {name} at offset {offset} sums to {sum(values):.6f}, not {want}")
        out[name] = values
    return out


def main():
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    tables = [extract(p) for p in sys.argv[1:]]
    for other, path in zip(tables[1:], sys.argv[2:]):
        if other != tables[0]:
            raise SystemExit(f"{path}: tables differ from {sys.argv[1]}")
    print("# Cycles' tables as compiled into bpy (PyPI): " + ", ".join(
        next((part for part in p.split("/") if part.startswith("bpy-")), p) for p in sys.argv[1:]))
    print("# by scripts/extract_cycles_tables.py; sums equal Blender v5.1.2's intern/cycles/scene/shader.tables")
    for name, count, _, _ in TABLES:
        v = tables[0][name]
        print(f"# {name} {count} {sum(v):.6f}")
        for i in range(0, count, ROW[name]):
            print(" ".join(f"{x:.6f}" for x in v[i:i + ROW[name]]))


if __name__ == "__main__":
    main()
