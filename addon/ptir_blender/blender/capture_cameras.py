"""A capture's cameras as Blender cameras, each with its photo as the camera's
background image (so an artist can look through a camera and compare the photo
with the render), in one collection. The capture's world frame is the scene's;
with `parent` the cameras follow that object (the splats trained on the capture).
"""

import os

import bpy
import mathutils

from ..io import capture_cameras

COLLECTION = "PTIR Capture Cameras"


def import_cameras(context, doc, parent=None, alpha=0.5):
    """Creates one camera object per frame of `doc` (io.capture_cameras.read_cameras); returns them."""
    scene = context.scene
    coll = bpy.data.collections.get(COLLECTION)
    if coll is None:
        coll = bpy.data.collections.new(COLLECTION)
        scene.collection.children.link(coll)
    w, h = int(doc["w"]), int(doc["h"])
    made = []
    for fr in doc["frames"]:
        c = capture_cameras.blender_camera(fr, w, h)
        name = str(fr.get("name") or os.path.splitext(os.path.basename(fr["file_path"]))[0])
        cam = bpy.data.cameras.new(name)
        cam.sensor_fit = c["sensor_fit"]
        cam.sensor_width = c["sensor_width"]
        cam.sensor_height = c["sensor_height"]
        cam.lens = c["lens"]
        cam.shift_x = c["shift_x"]
        cam.shift_y = c["shift_y"]
        obj = bpy.data.objects.new(name, cam)
        coll.objects.link(obj)
        obj.matrix_world = mathutils.Matrix(c["matrix"].tolist())
        if parent is not None:
            obj.parent = parent
            obj.matrix_parent_inverse = mathutils.Matrix.Identity(4)
        obj["ptir_image"] = fr["file_path"]  # what "Scene Cameras" optimisation reads
        img = bpy.data.images.load(fr["file_path"], check_existing=True)
        bg = cam.background_images.new()
        bg.image = img
        bg.alpha = alpha
        bg.display_depth = "FRONT"
        bg.frame_method = "STRETCH"
        cam.show_background_images = True
        made.append(obj)
    scene.render.resolution_x, scene.render.resolution_y = w, h
    scene.render.resolution_percentage = 100
    if made and scene.camera is None:
        scene.camera = made[0]
    return made
