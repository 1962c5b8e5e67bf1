"""Writes a copy of the Cornell splat sample whose splat object holds about 1M splats (bench only).

    blender -b sample_blends/cornell_splats.blend -P bench/make_million_splats.py -- OUT.blend [N]

Each of the sample's splats is replaced by N/2000 smaller ones scattered inside it (same materials), so
the object keeps its shape and the scene its look; the display shows a 20,000-splat subset.
"""

import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "blender"))
import addon_blender_harness as h  # noqa: E402

h.enable_addon()
from ptir_blender.blender import splat_display, splat_object  # noqa: E402


def main():
    out = h.argv()[0]
    n = int(h.argv()[1]) if len(h.argv()) > 1 else 1_000_000
    obj = bpy.data.objects["Suzanne Splats"]
    d = splat_object.read_data_from_object(obj)
    k = max(1, n // len(d))
    rng = np.random.default_rng(1)
    big = d.copy()
    for f in d.FIELDS:
        v = getattr(d, f)
        if f == "sh_rest":
            setattr(big, f, np.repeat(v, k, axis=1))
        elif isinstance(v, np.ndarray) and v.ndim >= 1 and len(v) == len(d):
            setattr(big, f, np.repeat(v, k, axis=0))
    big.extra = {name: np.repeat(v, k) for name, v in d.extra.items()}
    big.position = (big.position + rng.normal(size=big.position.shape) * big.scale * 0.5).astype(np.float32)
    big.scale = (big.scale / k ** (1.0 / 3.0) * 1.5).astype(np.float32)
    mesh = bpy.data.meshes.new("million")
    splat_object.write_data_to_mesh(mesh, big)
    old = obj.data
    obj.data = mesh
    bpy.data.meshes.remove(old)
    splat_display.add_display(obj, limit=20000)
    bpy.ops.wm.save_as_mainfile(filepath=out, compress=False)
    print("MILLION: %d splats -> %s" % (len(big), out), flush=True)


h.run(main)
