"""File > Import / Export > Gaussian Splats (.ply).

    bpy.ops.import_scene.gaussian_splat_ply(filepath="capture.ply")
    bpy.ops.export_scene.gaussian_splat_ply(filepath="out.ply")

Import reads the PLY with numpy (io/splat_ply.py: every variant the engine
reads, including SuperSplat compressed files) and builds a vertex-only mesh
object with the splat attributes (blender/splat_object.py) in bulk. A file that
cannot be read is reported with the property or problem named, and the scene is
left as it was. Export writes the active splat object (or, with "Selection
Only", every selected splat object merged) in the standard 3DGS layout plus
PTIR's material properties, with the object transforms folded in.
"""

import os
import time

import bpy
import numpy as np
from bpy.props import BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper, axis_conversion, orientation_helper
from mathutils import Matrix, Vector

from ..blender import splat_display, splat_object
from ..errors import PtirError
from ..io import splat_ply


def frame_views(context, objects):
    """Points every 3D view at the splats (robust bounds: 1st-99th percentile of the world positions, so
    stray floaters do not zoom out) and sets its clip range to fit. Splat objects' own bounding boxes
    are empty (their display is instanced), so view_selected cannot do this."""
    pts = []
    for obj in objects:
        n = len(obj.data.vertices)
        co = np.empty(n * 3, np.float32)
        obj.data.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)[:: max(1, n // 200000)]
        m = np.array(obj.matrix_world, np.float64)
        pts.append(co @ m[:3, :3].T + m[:3, 3])
    pts = np.concatenate(pts)
    lo, hi = np.percentile(pts, 1, axis=0), np.percentile(pts, 99, axis=0)
    centre, radius = (lo + hi) / 2.0, max(float(np.linalg.norm(hi - lo)) / 2.0, 1e-3)
    screen = context.window.screen if context.window else None
    for area in (screen.areas if screen else []):
        if area.type != "VIEW_3D":
            continue
        space = area.spaces.active
        r3d = space.region_3d
        if r3d.view_perspective == "CAMERA":
            r3d.view_perspective = "PERSP"
        r3d.view_location = Vector(centre)
        r3d.view_distance = radius * 3.0
        space.clip_start = max(1e-4, radius * 1e-3)
        space.clip_end = max(space.clip_end, radius * 50.0)
    return centre, radius


# The common conventions of splat PLYs, as (Forward, Up) of the file: "Axes" takes the Forward / Up
# properties as set. A trainer's PLY (3DGS, gsplat, nerfstudio; SuperSplat and PlayCanvas keep that
# frame) is in its COLMAP capture's frame, whose world is the first photo's camera: y down, z ahead;
# glTF and the web viewers' scenes are Y up with -Z ahead; PTIR's and Blender's own files are Z up.
AXIS_PRESETS = {"BLENDER": ("Y", "Z"), "TRAINER": ("Z", "-Y"), "Y_UP": ("-Z", "Y")}


def _apply_axis_preset(self, context):
    """Shows the preset's axes in the Forward / Up fields (execute uses the preset itself)."""
    if self.axis_preset in AXIS_PRESETS:
        self.axis_forward, self.axis_up = AXIS_PRESETS[self.axis_preset]


@orientation_helper(axis_forward="Y", axis_up="Z")
class IMPORT_SCENE_OT_gaussian_splat_ply(bpy.types.Operator, ImportHelper):
    """Import 3D Gaussian splats from a .ply file (3DGS, SuperSplat compressed), with PTIR materials"""
    bl_idname = "import_scene.gaussian_splat_ply"
    bl_label = "Gaussian Splats (.ply)"
    bl_options = {"REGISTER", "UNDO", "PRESET"}

    filename_ext = ".ply"
    filter_glob: StringProperty(default="*.ply", options={"HIDDEN"})
    files: CollectionProperty(type=bpy.types.OperatorFileListElement, options={"HIDDEN", "SKIP_SAVE"})
    directory: StringProperty(subtype="DIR_PATH", options={"HIDDEN", "SKIP_SAVE"})
    display: BoolProperty(name="Viewport Display", default=True,
                          description="Show the splats as ellipsoids in the viewport (Geometry Nodes)")
    display_limit: IntProperty(name="Display Limit", default=splat_display.DEFAULT_DISPLAY_LIMIT, min=0,
                               description="Show at most this many splats (a random subset; 0 = all)")
    display_size: FloatProperty(name="Splat Size", default=splat_display.DEFAULT_DISPLAY_SIZE, min=0.0,
                                description="Ellipsoid radii in standard deviations")
    axis_preset: EnumProperty(
        name="Convention", default="AXES", update=_apply_axis_preset,
        description="The file's axis convention: sets Forward / Up (stand the object up; Make Relightable "
                    "takes Blender's Z as its up)",
        items=[("AXES", "Forward / Up", "The Forward and Up axes as set below"),
               ("BLENDER", "Z Up (Blender, PTIR)", "Files written by Blender, PTIR or the add-on: Z up"),
               ("TRAINER", "-Y Up (3DGS, gsplat, nerfstudio, SuperSplat)",
                "A trainer's PLY in its COLMAP capture's frame: -Y up, +Z ahead (the first photo's camera)"),
               ("Y_UP", "Y Up (glTF, three.js, PlayCanvas)", "Y up, -Z ahead")])
    global_scale: FloatProperty(name="Scale", default=1.0, min=1e-6, soft_min=1e-3, soft_max=1e3,
                                description="Scale of the object (a capture in other units: 0.01 for centimetres)")
    frame: BoolProperty(name="Frame in View", default=True,
                        description="Point the 3D views at the splats and set their clip range to fit")

    def _matrix(self):
        """Object matrix: the file's axes (Forward / Up; trainers' captures are often Y-up or -Y-up) to
        Blender's, times the scale. Applied as the object's transform, not baked into the splats. A
        Convention other than Forward / Up gives the axes itself (a script need not set both)."""
        forward, up = AXIS_PRESETS.get(self.axis_preset, (self.axis_forward, self.axis_up))
        conv = axis_conversion(from_forward=forward, from_up=up).to_4x4()
        return Matrix.Scale(self.global_scale, 4) @ conv

    def execute(self, context):
        paths = [os.path.join(self.directory, f.name) for f in self.files if f.name] if self.files else []
        if not paths:
            paths = [self.filepath]
        # Read everything first: a bad file leaves the scene unchanged.
        read = []
        for p in paths:
            try:
                t0 = time.perf_counter()
                read.append((p, splat_ply.read_splat_ply(p), time.perf_counter() - t0))
            except PtirError as e:
                self.report({"ERROR"}, str(e))
                return {"CANCELLED"}
        if context.object is not None and context.object.mode != "OBJECT":
            bpy.ops.object.mode_set(mode="OBJECT")
        created = []
        for p, d, t_read in read:
            t0 = time.perf_counter()
            name = os.path.splitext(os.path.basename(p))[0] or "Splats"
            try:
                obj = splat_object.create_splat_object(context, d, name, display=self.display,
                                                       display_limit=self.display_limit,
                                                       display_size=self.display_size)
            except PtirError as e:
                for o in created:
                    bpy.data.objects.remove(o)
                self.report({"ERROR"}, str(e))
                return {"CANCELLED"}
            obj["ptir_source"] = os.path.abspath(p)
            obj.matrix_world = self._matrix()
            obj.ptir_splat.display_limit = int(self.display_limit)  # (updates the display modifier too)
            obj.ptir_splat.display_size = float(self.display_size)
            created.append(obj)
            print("ptir import: %s: %d splats (SH degree %d) read in %.2f s, object built in %.2f s"
                  % (p, len(d), d.sh_degree, t_read, time.perf_counter() - t0))
        for o in context.view_layer.objects:
            o.select_set(False)
        for o in created:
            o.select_set(True)
        context.view_layer.objects.active = created[-1]
        if self.frame and not bpy.app.background:
            frame_views(context, created)
        self.report({"INFO"}, "Imported %d splats" % sum(len(o.data.vertices) for o in created))
        return {"FINISHED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        col = layout.column(heading="Transform")
        col.prop(self, "axis_preset")
        axes = col.column()
        axes.active = self.axis_preset == "AXES"  # a preset gives both (shown, greyed)
        axes.prop(self, "axis_forward")
        axes.prop(self, "axis_up")
        col.prop(self, "global_scale")
        col.prop(self, "frame")
        layout.prop(self, "display")
        col = layout.column()
        col.enabled = self.display
        col.prop(self, "display_limit")
        col.prop(self, "display_size")


def export_objects(objects, filepath, apply_transform=True):
    """Writes the splat objects (merged, world space when apply_transform) to filepath; returns the count."""
    parts = []
    for obj in objects:
        parts.append(splat_object.world_data(obj) if apply_transform else splat_object.read_data_from_object(obj))
    if not parts:
        raise splat_object.SplatObjectError("no splat object to export")
    d = parts[0] if len(parts) == 1 else _merge(parts)
    splat_ply.write_splat_ply(filepath, d)
    return len(d)


def _merge(parts):
    k = max(p.sh_rest.shape[0] for p in parts)
    out = splat_ply.SplatData()
    for field in splat_ply.SplatData.FIELDS:
        if field == "sh_rest":  # (K, n, 3): pad lower degrees with zero coefficients
            arrays = [np.concatenate([p.sh_rest, np.zeros((k - p.sh_rest.shape[0], len(p), 3), np.float32)], axis=0)
                      for p in parts]
            setattr(out, field, np.concatenate(arrays, axis=1))
        else:
            setattr(out, field, np.concatenate([getattr(p, field) for p in parts], axis=0))
    names = set.intersection(*(set(p.extra) for p in parts))
    out.extra = {n: np.concatenate([p.extra[n] for p in parts]) for n in sorted(names)}
    return out


class EXPORT_SCENE_OT_gaussian_splat_ply(bpy.types.Operator, ExportHelper):
    """Export splat objects as a 3DGS .ply with PTIR's material properties (transforms folded in)"""
    bl_idname = "export_scene.gaussian_splat_ply"
    bl_label = "Gaussian Splats (.ply)"
    bl_options = {"REGISTER", "PRESET"}

    filename_ext = ".ply"
    filter_glob: StringProperty(default="*.ply", options={"HIDDEN"})
    use_selection: BoolProperty(name="Selection Only", default=False,
                                description="Export every selected splat object, merged into one file "
                                            "(default: the active splat object)")
    apply_transform: BoolProperty(name="Apply Transform", default=True,
                                  description="Fold the object transform into positions, scales and rotations")

    @classmethod
    def poll(cls, context):
        return any(splat_object.is_splat_object(o) for o in context.scene.objects)

    def _objects(self, context):
        if self.use_selection:
            return [o for o in context.selected_objects if splat_object.is_splat_object(o)]
        active = context.view_layer.objects.active
        if splat_object.is_splat_object(active):
            return [active]
        selected = [o for o in context.selected_objects if splat_object.is_splat_object(o)]
        if len(selected) == 1:
            return selected
        candidates = [o for o in context.scene.objects if splat_object.is_splat_object(o)]
        return candidates if len(candidates) == 1 else []

    def execute(self, context):
        objects = self._objects(context)
        if not objects:
            self.report({"ERROR"}, "No selected splat object to export" if self.use_selection
                        else "Make the splat object to export active (or use Selection Only)")
            return {"CANCELLED"}
        try:
            n = export_objects(objects, self.filepath, self.apply_transform)
        except PtirError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        self.report({"INFO"}, "Exported %d splats to %s" % (n, self.filepath))
        return {"FINISHED"}


def menu_import(self, context):
    self.layout.operator(IMPORT_SCENE_OT_gaussian_splat_ply.bl_idname, text="Gaussian Splats (.ply)")


def menu_export(self, context):
    self.layout.operator(EXPORT_SCENE_OT_gaussian_splat_ply.bl_idname, text="Gaussian Splats (.ply)")


classes = (IMPORT_SCENE_OT_gaussian_splat_ply, EXPORT_SCENE_OT_gaussian_splat_ply)
