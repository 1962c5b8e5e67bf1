"""bpy.ops.ptir.optimize with the scene's lamps and walls as known light (run by test_addon_known_lamps.py).

    blender -b ROOM.blend ... -P addon_known_lamps_check.py -- MODE DATASET_DIR WORK_DIR ITERATIONS

ROOM.blend is make_dataset.py --room lamps --save-blend: the object's meshes (collection PTIR_Object), the
floor, the wall and the two area lights (collection PTIR_Room). The object's meshes make way for its
splats (the dataset's gaussians.ply, imported); the Optimise panel reads the dataset folder.
MODE
  known   Environment None (scene lights only): the lamps, floor and wall are the only light and the
          known occluders; the World is left as it was (nothing comes back to put there)
  blind   the lamps hidden, a lat-long environment learnt (the floor and wall still take part)
  unlit   Environment None with the lamps hidden: refused before anything runs
Prints "LAMPS_STATS: {json}" (the output folder, the engine's recorded settings).
"""

import json
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402

h.enable_addon()
from ptir_blender.blender import optimize_job  # noqa: E402


def build_scene(dataset):
    coll = bpy.data.collections.get("PTIR_Object")
    h.check(coll is not None and len(coll.all_objects) > 0, "the room .blend has the object's meshes")
    for o in list(coll.all_objects):
        bpy.data.objects.remove(o)
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=os.path.join(dataset, "gaussians.ply"))
    h.check(r == {"FINISHED"}, "import the splats")
    splats = bpy.context.active_object
    lamps = [o for o in bpy.context.scene.objects if o.type == "LIGHT"]
    h.check(len(lamps) == 2 and all(optimize_job.is_scene_light(o) for o in lamps), "two lamps: %s" % lamps)
    return splats, lamps


def main():
    mode, dataset, work, iterations = h.argv()[:4]
    splats, lamps = build_scene(dataset)
    s = bpy.context.scene.ptir_optimize
    s.source = "DATASET"
    s.dataset_dir = dataset
    s.splat_object = splats
    s.iterations, s.spp, s.bounces = int(iterations), 4, 2
    s.fit_geometry = "OFF"
    s.optimize_meshes = False  # the walls are known
    s.write_environment = True
    s.output_dir = os.path.join(work, "out")
    s.env = "latlong" if mode == "blind" else "none"
    if mode in ("blind", "unlit"):
        for o in lamps:
            o.hide_render = True
    world_nodes = sorted(n.name for n in bpy.context.scene.world.node_tree.nodes)
    try:
        result, msg = bpy.ops.ptir.optimize(), ""
    except RuntimeError as e:  # ERROR reports raise in scripts
        result, msg = {"CANCELLED"}, str(e)
    stats = {"mode": mode, "out": s.output_dir, "message": msg}
    if mode == "unlit":
        h.check(result == {"CANCELLED"} and "no visible lamp or emissive mesh" in msg, "refused: %s" % msg)
    else:
        h.check(result == {"FINISHED"}, "optimize returned %s %s" % (result, msg))
        stats["settings"] = json.load(open(os.path.join(s.output_dir, "settings.json")))
        after = sorted(n.name for n in bpy.context.scene.world.node_tree.nodes)
        if mode == "known":
            h.check(after == world_nodes, "the World is left alone under scene lights only: %s -> %s"
                    % (world_nodes, after))
        else:
            h.check("PTIR Environment" in after, "the learnt environment is put into the World")
    print("LAMPS_STATS: " + json.dumps(stats), flush=True)


h.run(main)
