"""Import a capture's cameras (any dataset folder the engine reads) as Blender
cameras with the photo behind, to compare photo and render.

    bpy.ops.ptir.import_capture_cameras(directory="capture/", split="all")
"""

import os
import shutil
import tempfile

import bpy
from bpy.props import StringProperty

from ..blender import capture_cameras as bcams
from ..blender import preferences
from ..errors import PtirError
from ..io import capture_cameras


class PTIR_OT_import_capture_cameras(bpy.types.Operator):
    """Add the capture's cameras (NeRF, COLMAP, 3DGS output or nerfstudio folder) with each photo as the camera
    background"""
    bl_idname = "ptir.import_capture_cameras"
    bl_label = "Import Capture Cameras"
    bl_options = {"REGISTER", "UNDO"}

    directory: StringProperty(name="Capture", subtype="DIR_PATH",
                              description="Dataset folder (default: the Optimise panel's dataset)")
    split: StringProperty(name="Split", default="all", description="train, test or all")

    def invoke(self, context, event):
        if not self.directory and context.scene.ptir_optimize.dataset_dir:
            self.directory = context.scene.ptir_optimize.dataset_dir
        return self.execute(context) if self.directory else context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        folder = bpy.path.abspath(self.directory or context.scene.ptir_optimize.dataset_dir)
        tmp = tempfile.mkdtemp(prefix="ptir_cameras_")
        try:
            doc = capture_cameras.export_cameras(preferences.cli_path(), folder, os.path.join(tmp, "cameras.json"),
                                                 self.split or "all")
            parent = context.scene.ptir_optimize.splat_object
            made = bcams.import_cameras(context, doc, parent=parent)
        except PtirError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        self.report({"INFO"}, "Imported %d cameras of a %s capture (%dx%d)" % (len(made), doc["layout"], doc["w"],
                                                                                   doc["h"]))
        return {"FINISHED"}


classes = (PTIR_OT_import_capture_cameras,)
