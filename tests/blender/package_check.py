"""Installs the release zip (make package) into a Blender and renders a frame with it (run by test_package.py).

    <blender python> package_check.py MODE ZIP OUT_DIR            (bpy 4.5 / 5.0 as a module)
    blender -b --factory-startup -P package_check.py -- MODE ZIP OUT_DIR   (Blender 3.4)

MODE extension: Edit > Preferences > Get Extensions > Install from Disk, as Blender 4.2+ does it
  (bpy.ops.extensions.package_install_files into the "user_default" repository, enabled on install).
MODE legacy: Edit > Preferences > Add-ons > Install, as Blender 3.x does it
  (bpy.ops.preferences.addon_install, then the add-on enabled).

The caller points Blender's user folders (BLENDER_USER_*) into a temporary folder, strips PATH of
any `ptir` and unsets PTIR_CLI: the only engine the add-on can find is the one in the zip. Then a
small scene (a ground plane, a cube, an area light, a black world) is rendered with the PTIR
engine (F12), the Render Result saved as EXR and read back. Prints
"PACKAGE_STATS: {json}" (where the add-on was installed, which CLI it picked, whether the
bundled CLI was executable before and after the render, and image statistics) for the pytest
side to judge; exits non-zero on any error.
"""

import importlib
import json
import math
import os
import shutil
import sys
import traceback

import bpy


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    if len(argv) != 3 or argv[0] not in ("extension", "legacy"):
        raise SystemExit("usage: package_check.py extension|legacy ZIP OUT_DIR")
    return argv


def install(mode, zip_path):
    """Installs and enables the zip; returns (the add-on's module name, its folder)."""
    if mode == "extension":
        result = bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                                          enable_on_install=True)
        if result != {"FINISHED"}:
            raise RuntimeError("extensions.package_install_files returned %s" % result)
        repo = next(r for r in bpy.context.preferences.extensions.repos if r.module == "user_default")
        module, folder = "bl_ext.user_default.ptir_blender", os.path.join(repo.directory, "ptir_blender")
    else:
        import addon_utils
        result = bpy.ops.preferences.addon_install(filepath=zip_path)
        if result != {"FINISHED"}:
            raise RuntimeError("preferences.addon_install returned %s" % result)
        if addon_utils.enable("ptir_blender", default_set=True) is None:
            raise RuntimeError("addon_utils.enable('ptir_blender') failed")
        module = "ptir_blender"
        folder = os.path.join(bpy.utils.user_resource("SCRIPTS", path="addons"), "ptir_blender")
    if module not in bpy.context.preferences.addons:
        raise RuntimeError("%s is not enabled after installing (enabled: %s)"
                           % (module, sorted(bpy.context.preferences.addons.keys())))
    return module, folder


def mesh_object(name, verts, faces, location=(0.0, 0.0, 0.0)):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    bpy.context.scene.collection.objects.link(obj)
    return obj


def build_scene():
    """A ground plane, a unit cube on it, an area light above, a camera; no world (black)."""
    scene = bpy.context.scene
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    mesh_object("ground", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], [(0, 1, 2, 3)])
    c = [(x, y, z) for z in (0, 1) for y in (-0.5, 0.5) for x in (-0.5, 0.5)]
    mesh_object("cube", c, [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)])

    light = bpy.data.lights.new("area", "AREA")
    light.energy = 60.0
    light.size = 1.5
    light_obj = bpy.data.objects.new("area", light)
    light_obj.location = (0.5, -0.5, 3.0)
    scene.collection.objects.link(light_obj)

    cam = bpy.data.cameras.new("camera")
    cam_obj = bpy.data.objects.new("camera", cam)
    cam_obj.location = (5.0, -5.0, 3.5)
    # Looking at (0, 0, 0.5): the ground fills the lower part of the frame, the black world the top.
    d = (-5.0, 5.0, -3.0)
    cam_obj.rotation_euler = (math.atan2(math.hypot(d[0], d[1]), -d[2]), 0.0,
                              math.atan2(d[1], d[0]) - math.pi / 2)
    scene.collection.objects.link(cam_obj)
    scene.camera = cam_obj
    scene.world = None

    scene.render.engine = "PTIR"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
    scene.render.film_transparent = False
    scene.ptir_render.spp = 8
    scene.ptir_render.bounces = 1
    return scene


def render_pixels(scene, out_dir):
    bpy.ops.render.render()
    path = os.path.join(out_dir, "render.exr")
    settings = scene.render.image_settings
    settings.file_format = "OPEN_EXR"
    settings.color_depth = "32"
    bpy.data.images["Render Result"].save_render(path)
    img = bpy.data.images.load(path, check_existing=False)
    w, h = img.size
    px = [0.0] * (w * h * 4)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    rows = [[px[4 * (y * w + x): 4 * (y * w + x) + 3] for x in range(w)] for y in range(h)]  # bottom-up
    return w, h, rows


def main():
    mode, zip_path, out_dir = args()
    stats = {"blender": bpy.app.version_string, "mode": mode,
             "ptir_on_path": shutil.which("ptir"), "PTIR_CLI": os.environ.get("PTIR_CLI")}
    module, folder = install(mode, os.path.abspath(zip_path))
    bundled = os.path.join(folder, "bin", "ptir")
    stats.update(module=module, folder=folder, bundled=bundled,
                 bundled_exists=os.path.isfile(bundled), executable_before=os.access(bundled, os.X_OK))

    render_engine = importlib.import_module(module + ".operators.render_engine")
    cli = importlib.import_module(module + ".io.cli")
    stats["cli_picked"] = render_engine.cli_path()
    # An explicit preference overrides the bundled copy.
    prefs = bpy.context.preferences.addons[module].preferences
    prefs.cli_path = "/bin/true"
    stats["cli_with_preference"] = render_engine.cli_path()
    prefs.cli_path = ""
    stats["bundled_cli"] = cli.bundled_cli()

    scene = build_scene()
    w, h, rows = render_pixels(scene, out_dir)
    stats["executable_after"] = os.access(bundled, os.X_OK)
    lum = [[sum(p) / 3.0 for p in row] for row in rows]
    flat = [v for row in lum for v in row]
    top = [v for row in lum[-h // 6:] for v in row]   # the top sixth of the frame (rows are bottom-up)
    stats.update(width=w, height=h, finite=all(math.isfinite(v) for v in flat),
                 mean=sum(flat) / len(flat), max=max(flat),
                 lit_fraction=sum(v > 1e-3 for v in flat) / len(flat),
                 dark_fraction=sum(v < 1e-6 for v in flat) / len(flat),
                 top_mean=sum(top) / len(top))
    print("PACKAGE_STATS: " + json.dumps(stats), flush=True)


if __name__ == "__main__":
    try:
        main()
    except BaseException:
        traceback.print_exc()
        sys.stdout.flush()
        os._exit(1)
