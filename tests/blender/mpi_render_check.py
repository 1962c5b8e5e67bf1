"""Blender side of test_mpi_blender.py: the README's recipe of a PTIR engine render through an
mpirun wrapper set as the add-on's 'ptir command' preference, against the same render through
the plain CLI.

    blender -b cornell_splats.blend -P mpi_render_check.py -- TMP WRAPPER
"""

import json
import os
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402
import blender_kit as kit  # noqa: E402  (scripts/, put on sys.path by the harness)

h.enable_addon()


def render(path):
    scene = bpy.context.scene
    kit.exr_output(scene)
    t0 = time.perf_counter()
    kit.render_still(scene, path)
    return kit.read_pixels(path), time.perf_counter() - t0


def main():
    tmp, wrapper = h.argv()[:2]
    scene = bpy.context.scene
    h.check(scene.render.engine == "PTIR", "the sample .blend uses the PTIR engine")
    scene.render.resolution_percentage = 25  # 64 x 64
    s = scene.ptir_render
    s.spp, s.bounces, s.seed = 8, 2, 3
    plain, plain_s = render(os.path.join(tmp, "plain.exr"))
    bpy.context.preferences.addons["ptir_blender"].preferences.cli_path = wrapper
    ranks, ranks_s = render(os.path.join(tmp, "mpi.exr"))
    h.check(plain.shape == ranks.shape and plain.shape[:2] == (64, 64), "render sizes %s %s" % (plain.shape, ranks.shape))
    plain, ranks = plain[..., :3], ranks[..., :3]
    h.check(plain.mean() > 0.02, "a lit image")
    # Bands differ from the whole image by the last bit of jittered camera rays (render/row_bands.h):
    # float rounding, except where a ray grazes an edge. Misplaced or missing bands are O(0.1).
    diff = np.abs(plain - ranks) / np.maximum(1.0, np.abs(plain))
    stats = {"max_rel_diff": float(diff.max()), "mean_rel_diff": float(diff.mean()), "plain_s": plain_s,
             "mpi_s": ranks_s}
    print("MPI_RENDER_STATS: " + json.dumps(stats))
    h.check(diff.max() <= 1e-3 and diff.mean() <= 1e-6, "the mpirun render differs: %s" % stats)


h.run(main)
