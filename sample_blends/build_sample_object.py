"""Builds sample_blends/sample_object.blend: the source scene of the bundled sample dataset.

    blender -b --factory-startup -noaudio --python-exit-code 1 -P sample_blends/build_sample_object.py \
        [-- --out sample_blends/sample_object.blend --subdiv 2]

The object (scripts/dataset/scene.py, build_sample_object): Suzanne, smooth-shaded
with Catmull-Clark level 2, resting on a closed box pedestal; four Principled BSDF
parts with metallic 0 (linear base colour, roughness):

    head           (0.80, 0.30, 0.10)  0.30
    eyes           (0.85, 0.85, 0.80)  0.20
    pedestal_top   (0.60, 0.60, 0.55)  0.80
    pedestal_side  (0.08, 0.30, 0.45)  0.50

scaled into a bounding sphere of radius 1.25 at the origin, in collection
"PTIR_Object". Every material carries an AOV Output "roughness" (the ground-truth
roughness pass) and custom properties ptir_base_color / ptir_roughness /
ptir_metallic. No cameras, lights or world: scripts/make_dataset.py adds them:

    blender -b --factory-startup -noaudio --python-exit-code 1 -P scripts/make_dataset.py -- \
        --blend sample_blends/sample_object.blend --out out/sample_dataset
"""

import argparse
import os
import sys

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scripts"))

from dataset import scene as dscene  # noqa: E402


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="build_sample_object.py")
    p.add_argument("--out", default=os.path.join(HERE, "sample_object.blend"))
    p.add_argument("--subdiv", type=int, default=2)
    a = p.parse_args(argv)
    dscene.clear_scene()
    objs = dscene.build_sample_object(subdiv=a.subdiv)
    bpy.context.scene.render.engine = "CYCLES"
    bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(a.out), compress=True)
    print("build_sample_object: %d objects -> %s" % (len(objs), os.path.abspath(a.out)))


if __name__ == "__main__":
    try:
        main()
    except Exception as e:
        import traceback
        traceback.print_exc()
        print("build_sample_object: error: %s" % e, file=sys.stderr)
        sys.exit(1)
