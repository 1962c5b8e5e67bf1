"""Film > Transparent through the PTIR engine against this Blender's Cycles (run by test_alpha_edges.py).

    blender -b ... -P addon_alpha_check.py -- MODE TMPDIR SIZE SPP

MODE mesh:  three flat-shaded icospheres with Principled materials (only Base Color set), no ground,
            lit by a sun and a sky colour, the world hidden by Film > Transparent.
MODE splat: one icosphere; Cycles renders the mesh, PTIR its surface-splat twin (one flat Gaussian
            per triangle, addon/ptir_blender/io/surface_splats.py, the sphere's material), imported
            with the add-on's PLY importer: soft splat edges along the silhouette.
Each engine renders the scene twice at SIZE x SIZE, SPP samples, 3 bounces, a Box pixel filter of 1 px:
  <engine>_raw.npy   the Render Result as Blender holds it (float32 RGBA, row 0 = top)
  <engine>_over.npy  the compositor's Alpha Over of that render over a constant colour (BACKGROUND)
and the PTIR Render Result must be `ptir render --transparent`'s image of the exported scene, pixel
for pixel (RGBA). Prints "ALPHA_STATS: {json}".
"""

import json
import math
import os
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_blender_harness as h  # noqa: E402
import blender_kit as kit  # noqa: E402

h.enable_addon()
from ptir_blender.blender import compat, scene_bridge  # noqa: E402
from ptir_blender.io import surface_splats  # noqa: E402
from ptir_blender.operators import render_engine  # noqa: E402

BACKGROUND = (0.25, 0.35, 0.3)
BOUNCES = 3


def principled(name, colour):
    m = bpy.data.materials.new(name)
    compat.ensure_nodes(m).nodes["Principled BSDF"].inputs["Base Color"].default_value = (*colour, 1.0)
    return m


def sphere(location, colour, subdivisions):
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=subdivisions, radius=0.45, location=location)
    obj = bpy.context.active_object
    obj.data.materials.append(principled("sphere %.1f" % location[0], colour))
    return obj


def build(mode, size):
    kit.reset_scene()
    scene = bpy.context.scene
    if mode == "mesh":
        objs = [sphere((x, 0.0, 0.45), c, 3)
                for x, c in ((-1.0, (0.8, 0.2, 0.1)), (0.0, (0.2, 0.6, 0.2)), (1.0, (0.1, 0.2, 0.8)))]
    else:
        objs = [sphere((0.0, 0.0, 0.45), (0.8, 0.45, 0.2), 5)]
    kit.add_light(scene, "SUN", 3.0, rotation=(math.radians(40.0), 0.0, math.radians(30.0)))
    kit.set_world_colour(scene, (0.4, 0.5, 0.7))
    kit.add_camera(scene, (0.0, -4.0, 1.4), (0.0, 4.0, -0.95), fov_x=math.radians(45.0 if mode == "mesh" else 17.0))
    kit.plain_cycles(scene, size, 1, threads=2, transparent=True)
    kit.match_estimator(scene, BOUNCES)
    return objs


def splat_twin(obj, folder):
    """The mesh's surface splats with its material, imported as a splat object (hidden from Cycles)."""
    me = obj.data
    v = np.array([obj.matrix_world @ p.co for p in me.vertices], np.float64)
    me.calc_loop_triangles()
    t = np.array([tri.vertices[:] for tri in me.loop_triangles], np.int64)
    g = surface_splats.triangles_to_gaussians(v, t)
    path = os.path.join(folder, "twin.ply")
    surface_splats.write_gaussians_ply(path, g, albedo=(0.8, 0.45, 0.2), roughness=0.5, metallic=0.0)
    r = bpy.ops.import_scene.gaussian_splat_ply(filepath=path)
    h.check(r == {"FINISHED"}, "import the splat twin")
    return bpy.context.active_object


def compositor_tree(scene):
    """An empty compositor node tree in use, and the node that takes its output (3.4 / 4.5: the
    scene's tree and a Composite node; 5.0: a node group with an Image output)."""
    if hasattr(scene, "compositing_node_group"):
        tree = bpy.data.node_groups.new("alpha over", "CompositorNodeTree")
        tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
        scene.compositing_node_group = tree
        return tree, tree.nodes.new("NodeGroupOutput").inputs[0]
    scene.use_nodes = True
    tree = scene.node_tree
    tree.nodes.clear()
    return tree, tree.nodes.new("CompositorNodeComposite").inputs["Image"]


def alpha_over_background(scene):
    """Render Layers -> Alpha Over (its default: the foreground is premultiplied) over BACKGROUND."""
    tree, out = compositor_tree(scene)
    layers = tree.nodes.new("CompositorNodeRLayers")
    rgb = tree.nodes.new("CompositorNodeRGB")
    rgb.outputs[0].default_value = (*BACKGROUND, 1.0)
    over = tree.nodes.new("CompositorNodeAlphaOver")
    background = over.inputs["Background"] if "Background" in over.inputs else over.inputs[1]
    foreground = over.inputs["Foreground"] if "Foreground" in over.inputs else over.inputs[2]
    tree.links.new(rgb.outputs[0], background)
    tree.links.new(layers.outputs["Image"], foreground)
    tree.links.new(over.outputs["Image"], out)


def render_result(path):
    """Renders the scene and returns the Render Result (or the composite) as float (h, w, 4), row 0 = top."""
    t0 = time.perf_counter()
    bpy.ops.render.render()
    seconds = time.perf_counter() - t0
    st = bpy.context.scene.render.image_settings
    st.file_format, st.color_depth, st.color_mode = "OPEN_EXR", "32", "RGBA"
    bpy.data.images["Render Result"].save_render(path)
    return kit.read_pixels(path)[::-1].copy(), seconds


def cli_difference(tmp, ptir_raw):
    """Max |F12 - CLI| over RGBA: the scene exported as F12 exports it, `ptir render --transparent`."""
    import subprocess
    s = bpy.context.scene.ptir_render
    scene_json, _ = scene_bridge.export_engine_scene(bpy.context, os.path.join(tmp, "export"),
                                                     integrator=render_engine.integrator_settings(s))
    out = os.path.join(tmp, "cli.exr")
    args = render_engine.render_args(render_engine.cli_path(), scene_json, out, scene_bridge.scene_camera_name(
        bpy.context.scene), s, transparent=True)
    r = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    h.check(r.returncode == 0, "CLI render failed: %s" % r.stderr[-2000:])
    return float(np.abs(kit.read_pixels(out)[::-1] - ptir_raw).max())


def main():
    mode, tmp, size, spp = h.argv()[0], h.argv()[1], int(h.argv()[2]), int(h.argv()[3])
    objs = build(mode, size)
    scene = bpy.context.scene
    splats = splat_twin(objs[0], tmp) if mode == "splat" else None
    alpha_over_background(scene)
    stats = {"blender": bpy.app.version_string, "mode": mode, "size": size, "spp": spp}
    for engine in ("CYCLES", "PTIR"):
        scene.render.engine = engine
        scene.cycles.samples = spp
        scene.cycles.seed = 1
        s = scene.ptir_render
        s.spp, s.bounces, s.seed = spp, BOUNCES, 1
        if splats is not None:  # Cycles renders the mesh, PTIR its splat twin
            objs[0].hide_render = engine == "PTIR"
            splats.hide_render = engine == "CYCLES"
        name = engine.lower()
        for kind, compositing in (("raw", False), ("over", True)):
            scene.render.use_compositing = compositing
            img, sec = render_result(os.path.join(tmp, "%s_%s.exr" % (name, kind)))
            h.check(img.shape == (size, size, 4), "%s %s: size %s" % (engine, kind, img.shape))
            np.save(os.path.join(tmp, "%s_%s.npy" % (name, kind)), img)
            stats["%s_%s_s" % (name, kind)] = round(sec, 2)
            if engine == "PTIR" and kind == "raw":
                stats["f12_vs_cli_max_abs"] = cli_difference(tmp, img)
                h.check(stats["f12_vs_cli_max_abs"] == 0.0, "F12 and `ptir render --transparent` differ")
    print("ALPHA_STATS: " + json.dumps(stats), flush=True)


h.run(main)
