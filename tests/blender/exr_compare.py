"""Prints "EXR_DIFF: <max |a - b| over RGB>" of two EXR files of the same size (read through Blender).

    blender -b -P exr_compare.py -- a.exr b.exr
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402
import blender_kit as kit  # noqa: E402


def main():
    a, b = (kit.read_pixels(p) for p in h.argv()[:2])
    h.check(a.shape == b.shape, "sizes differ: %s vs %s" % (a.shape, b.shape))
    print("EXR_DIFF: %.9g" % float(abs(a[..., :3] - b[..., :3]).max()), flush=True)


h.run(main)
