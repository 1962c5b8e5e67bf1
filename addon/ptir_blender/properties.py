"""Settings of the add-on: PropertyGroups attached with PointerProperty, and the add-on preferences.

    scene.ptir_render     PTIRRenderSettings     the PTIR render engine (Render Properties)
    scene.ptir_optimize   PTIROptimizeSettings   the Optimise panel (3D viewport sidebar, PTIR tab)
    scene.ptir_edit       PTIREditSettings       the material editing panel
    object.ptir_splat     PTIRSplatSettings      a splat object's viewport display
    material.ptir         PTIRMaterialSettings   whether the optimiser recovers this mesh material
"""

import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, FloatVectorProperty, IntProperty,
                       PointerProperty, StringProperty)

from .blender import splat_display, splat_object


def _update_display(self, context):
    obj = self.id_data
    if not isinstance(obj, bpy.types.Object) or not splat_object.is_splat_object(obj):
        return
    if obj.modifiers.get(splat_display.DISPLAY_MODIFIER) is None:
        return
    splat_display.set_display_input(obj, "Mode", splat_display.DISPLAY_MODES.index(self.display))
    splat_display.set_display_input(obj, "Size", float(self.display_size))
    n = max(1, len(obj.data.vertices))
    fraction = 1.0 if self.display_limit <= 0 else min(1.0, self.display_limit / n)
    splat_display.set_display_input(obj, "Fraction", float(fraction))


class PTIRSplatSettings(bpy.types.PropertyGroup):
    display: EnumProperty(
        name="Display",
        description="What the viewport shows on the splats",
        items=[("COLOR", "Colour", "The captured colour (SH DC term)"),
               ("ALBEDO", "Albedo", "The recovered albedo"),
               ("ROUGHNESS", "Roughness", "The recovered roughness (grey)"),
               ("METALLIC", "Metallic", "The recovered metallic (grey)"),
               ("NORMAL", "Normal", "The shading normal (0.5 + 0.5 n)")],
        default="COLOR", update=_update_display)
    display_size: FloatProperty(
        name="Splat Size", description="Ellipsoid radii in standard deviations", default=1.5, min=0.0,
        soft_max=4.0, update=_update_display)
    display_limit: IntProperty(
        name="Display Limit", description="Show at most this many splats (a random subset; 0 = all)",
        default=splat_display.DEFAULT_DISPLAY_LIMIT, min=0, update=_update_display)


class PTIRRenderSettings(bpy.types.PropertyGroup):
    spp: IntProperty(name="Samples", description="Samples per pixel", default=32, min=1, soft_max=4096)
    bounces: IntProperty(name="Bounces", description="Indirect bounces (0: direct light only)", default=2, min=0,
                         soft_max=16)
    interaction: EnumProperty(
        name="Interaction", description="How a ray interacts with the Gaussians it passes",
        items=[("aggregate", "Aggregate", "One interaction from the weighted aggregate of the hits (PTIR)"),
               ("discrete", "Discrete", "One Gaussian picked with probability proportional to its weight")],
        default="aggregate")
    tau_g: FloatProperty(name="Validity Threshold", description="Accumulated opacity that makes a surface",
                         default=0.5, min=0.0, max=1.0)
    seed: IntProperty(name="Seed", description="Random seed (same seed, same image)", default=0, min=0)
    threads: IntProperty(name="Threads", description="Worker threads (0: all)", default=0, min=0)
    viewport_samples: IntProperty(
        name="Viewport Samples", description="Samples per pixel the Rendered viewport accumulates (1 per pass)",
        default=16, min=1, soft_max=1024)
    viewport_pixel_size: IntProperty(
        name="Viewport Pixel Size", description="The Rendered viewport renders at 1/N of the view's resolution "
        "(its first pass at a quarter of that)", default=2, min=1, max=16)
    aov_passes: BoolProperty(
        name="AOV Passes", description="F12 adds the render passes Depth, Normal, Albedo, Roughness, Metallic "
        "and Opacity (for the compositor)", default=True)


class PTIROptimizeSettings(bpy.types.PropertyGroup):
    source: EnumProperty(
        name="Views", description="Where the training images and camera poses come from",
        items=[("DATASET", "Dataset Folder", "A capture folder: NeRF (transforms_<split>.json), COLMAP, 3DGS output "
                                             "or nerfstudio"),
               ("CAMERAS", "Scene Cameras", "The scene's cameras, each with an image (custom property "
                                            "'ptir_image' or its first background image)"),
               ("SPLATS", "Splats' Own Radiance", "No photos: views around the splats rendered from their own "
                                                  "captured radiance (ptir optimize without --dataset)")],
        default="DATASET")
    dataset_dir: StringProperty(name="Dataset", description="Capture folder: NeRF (transforms_train.json), COLMAP "
                                "(sparse/0), 3DGS output (cameras.json) or nerfstudio (transforms.json)",
                                subtype="DIR_PATH")
    split: StringProperty(name="Split", description="Dataset split: NeRF reads transforms_<split>.json; other captures "
                                                 "hold out every 8th photo (train, test or all)", default="train")
    splat_object: PointerProperty(
        name="Splats", type=bpy.types.Object, description="The splat object whose materials are recovered",
        poll=lambda self, obj: splat_object.is_splat_object(obj))
    optimize_meshes: BoolProperty(
        name="Mesh Materials", default=False,
        description="Also recover the materials ticked below (Principled BSDF base colour, roughness, metallic)")
    optimize_metallic: BoolProperty(name="Metallic", default=False,
                                    description="Also recover metallic (otherwise it stays 0)")
    learn_exposure: BoolProperty(name="Learn Exposure", default=False,
                                 description="Learn one exposure scale per photo (photos without EXIF exposure "
                                             "that differ in brightness)")
    env: EnumProperty(
        name="Environment", description="Model of the recovered environment light; the scene's visible lamps, "
        "emissive meshes and walls always take part as known light and occluders",
        items=[("latlong", "Lat-long", "A lat-long texture"),
               ("sg", "Spherical Gaussians", "24 spherical Gaussians (smooth)"),
               ("none", "None (Scene Lights Only)", "No environment: the scene's visible lamps and emissive "
                                                    "meshes are the only light, known and fixed, its meshes "
                                                    "known occluders (ptir optimize --env none)")],
        default="latlong")
    env_width: IntProperty(name="Env Width", default=128, min=4, max=4096)
    env_height: IntProperty(name="Env Height", default=64, min=2, max=2048)
    # Issue 52: the light the artist knows. Known: the World's light (its Environment Texture, strength
    # and Mapping rotation) handed to the engine as --env-init, lined up with the photos (yaw) and kept
    # fixed; Known + Refine: learnt gently from there (--env-refine). Learn: recovered, as before.
    light: EnumProperty(
        name="Light", description="What the optimisation knows of the light",
        items=[("LEARN", "Learn", "Recover the environment light from the photos"),
               ("KNOWN", "Known (the World)", "The World's light, lined up with the photos (its rotation), "
                                              "kept fixed"),
               ("KNOWN_REFINE", "Known + Refine", "The World's light, lined up with the photos, then learnt "
                                                  "gently")],
        default="LEARN")
    write_environment: BoolProperty(
        name="Set World", default=True,
        description="Put the recovered environment into the world as an Environment Texture")
    # The geometry stage (`ptir fit`, issue 12) before the materials, as `ptir optimize` runs it by
    # default: on for dataset folders (captures in COLMAP, nerfstudio or 3DGS-output layout, whose
    # splats a rasteriser trained; NeRF-layout sets too, unless meshes of the scene take part),
    # off for Scene Cameras.
    fit_geometry: EnumProperty(
        name="Fit Geometry", description="First fit the splats' geometry, opacity, radiance and shading normals "
        "to the photos by ray tracing (ptir fit); the object's splats are replaced by the fitted ones",
        items=[("AUTO", "Auto", "On for dataset folders (a NeRF-layout one only when no scene mesh takes part), "
                                "off for Scene Cameras"),
               ("ON", "On", "Always fit the geometry first"),
               ("OFF", "Off", "Keep the splats' geometry as it is")],
        default="AUTO")
    fit_iterations: IntProperty(name="Fit Iterations", description="Iterations of the geometry fit", default=1500,
                                min=1, soft_max=30000)
    # Time presets (issue 38): the run ends within the preset's minutes (`ptir fit --budget` for the
    # geometry stage, at most 20 % of them, then `ptir optimize --budget`, which plans its samples and
    # iterations from the measured cost). Custom: the iteration count and samples below, a
    # reproducible run. Decision: Custom stays the default, so a saved file and a script that set
    # Iterations keep doing what they did; an artist picks a time.
    preset: EnumProperty(
        name="Quality", description="How long the optimisation may take (the iterations are planned to end in time)",
        items=[("CUSTOM", "Custom", "The iterations and samples below (a reproducible run)"),
               ("DRAFT", "Draft", "About 2 minutes"),
               ("GOOD", "Good", "About 10 minutes"),
               ("FINAL", "Final", "About 30 minutes")],
        default="CUSTOM")
    iterations: IntProperty(name="Iterations", default=800, min=1, soft_max=5000)
    spp: IntProperty(name="Samples", description="Samples per pixel per iteration", default=32, min=1)
    bounces: IntProperty(name="Bounces", default=2, min=0, soft_max=8)
    seed: IntProperty(name="Seed", default=0, min=0)
    views_per_iter: IntProperty(name="Views/Iteration", default=1, min=1)
    crop: IntProperty(name="Crop", description="Random square crops of this side (0: whole images)", default=0,
                      min=0)
    threads: IntProperty(name="Threads", description="Worker threads (0: all)", default=0, min=0)
    output_dir: StringProperty(
        name="Output", subtype="DIR_PATH",
        description="Folder for the optimiser's outputs (empty: a temporary folder, removed afterwards)")
    # The measured duration estimate (blender/optimize_estimate.py), saved with the file.
    estimate_key: StringProperty(default="", options={"HIDDEN"})
    estimate_setup_s: FloatProperty(default=0.0, min=0.0, options={"HIDDEN"})
    estimate_s_per_iter: FloatProperty(default=0.0, min=0.0, options={"HIDDEN"})
    estimate_fit_s_per_iter: FloatProperty(default=0.0, min=0.0, options={"HIDDEN"})  # 0: no fit stage
    # Live state of a running optimisation (shown by the panel).
    running: BoolProperty(default=False, options={"SKIP_SAVE"})
    progress: FloatProperty(default=0.0, min=0.0, max=1.0, subtype="FACTOR", options={"SKIP_SAVE"})
    status: StringProperty(default="", options={"SKIP_SAVE"})
    # What `ptir optimize` made of a real capture's splat: "object against a background" or "scene".
    capture_subject: StringProperty(default="", options={"SKIP_SAVE"})


class PTIREditSettings(bpy.types.PropertyGroup):
    channel: EnumProperty(
        name="Channel",
        items=[("ALBEDO", "Albedo", "Per-splat albedo (linear RGB)"),
               ("ROUGHNESS", "Roughness", "Per-splat roughness"),
               ("METALLIC", "Metallic", "Per-splat metallic")],
        default="ALBEDO")
    operation: EnumProperty(
        name="Operation",
        items=[("SET", "Set", "Replace the value"),
               ("TINT", "Tint", "Multiply the albedo by a colour"),
               ("SCALE", "Scale", "Multiply by a factor")],
        default="SET")
    color: FloatVectorProperty(name="Colour", subtype="COLOR", size=3, default=(0.8, 0.8, 0.8), min=0.0, max=1.0)
    value: FloatProperty(name="Value", default=0.5, min=0.0, soft_max=2.0)
    vertex_group: StringProperty(name="Vertex Group",
                                 description="Edit this group's splats (empty: the edit-mode selection, or all "
                                             "splats in object mode)")


class PTIRMaterialSettings(bpy.types.PropertyGroup):
    optimize: BoolProperty(name="Optimise", default=False,
                           description="Recover this material with the splats' materials")


class PTIRPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    cli_path: StringProperty(
        name="ptir Command", subtype="FILE_PATH",
        description="The engine's command-line tool (empty: the copy inside the add-on, then $PTIR_CLI, "
                    "then 'ptir' on PATH)")
    keep_files: BoolProperty(
        name="Keep Job Files", default=False,
        description="Keep the exported scenes, logs and outputs of renders and optimisations (for debugging)")

    def draw(self, context):
        col = self.layout.column()
        col.prop(self, "cli_path")
        col.prop(self, "keep_files")
        from .io import cli
        try:
            col.label(text="Using: %s" % cli.find_cli(self.cli_path), icon="CHECKMARK")
        except cli.JobError as e:
            col.label(text=str(e), icon="ERROR")


def preferences(context=None):
    context = context or bpy.context
    addon = context.preferences.addons.get(__package__)
    return addon.preferences if addon is not None else None


classes = (PTIRSplatSettings, PTIRRenderSettings, PTIROptimizeSettings, PTIREditSettings, PTIRMaterialSettings,
           PTIRPreferences)

_POINTERS = (
    (bpy.types.Scene, "ptir_render", PTIRRenderSettings),
    (bpy.types.Scene, "ptir_optimize", PTIROptimizeSettings),
    (bpy.types.Scene, "ptir_edit", PTIREditSettings),
    (bpy.types.Object, "ptir_splat", PTIRSplatSettings),
    (bpy.types.Material, "ptir", PTIRMaterialSettings),
)


def register_pointers():
    for owner, name, cls in _POINTERS:
        setattr(owner, name, PointerProperty(type=cls))


def unregister_pointers():
    for owner, name, _ in reversed(_POINTERS):
        if hasattr(owner, name):
            delattr(owner, name)
