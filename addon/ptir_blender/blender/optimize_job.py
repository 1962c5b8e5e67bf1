"""Optimisation jobs, Blender side: the inputs of `ptir optimize` from the scene, and writing its
recovered materials back.

prepare(context, settings, job_dir) writes
    job_dir/splats.ply            the splat object in world space (transform folded in)
    job_dir/scene/scene.json      the other visible meshes and lights (when there are any)
    job_dir/views/transforms_<split>.json   the training views in world space (scene cameras with
                                  images, or the dataset's views moved with the splat object; the
                                  dataset folder itself when the object has the identity transform)
and returns an OptimizeJob with the command lines: with the geometry stage (settings.fit_geometry,
wants_fit) first `ptir fit` into OUT/fit/ (OUT/fit/gaussians.ply: the fitted splats, kept beside the
output), then `ptir optimize` on the fitted splats; else `ptir optimize` alone. The dataset's cameras
are in the frame of the splat PLY the object was imported from, i.e. the object's local frame.

load_results(job) reads and checks everything the optimiser wrote (nothing in Blender changes);
apply_results(results) then writes it into the scene in one go: the splat attributes
(ptir_albedo, ptir_roughness, ptir_metallic, ptir_normal) -- after a fit, the object's whole splat
mesh (the fitted count, positions, scales, rotations, opacities, radiance, in its local frame) -- the Principled BSDF values of the ticked
mesh materials (material_writeback.py: the recovered base colour, roughness and metallic with the
other inputs the engine rendered them with, in this Blender's Principled model), and the world's Environment Texture. A failed or cancelled run never reaches
apply_results, so it leaves the scene unchanged.
"""

import json
import os

import bpy
import numpy as np

from ..io import capture_cameras, dataset_file, engine_client, scene_file, splat_ply, splat_transform
from . import compat, known_world, material_export, material_writeback, scene_bridge, scene_export, splat_object
from ..errors import OptimizeError

ENV_NODE = "PTIR Environment"

# The time presets and the fit's share of them live with the command lines (io/engine_client.py).
PRESET_SECONDS = engine_client.PRESET_SECONDS
FIT_SHARE = engine_client.FIT_SHARE
preset_seconds = engine_client.preset_seconds


def inversion_args(job, elapsed_s):
    """The inversion's command line once the stages before it took `elapsed_s` seconds
    (engine_client.inversion_args: under a time preset, the --budget the preset has left)."""
    return engine_client.inversion_args(job.args, job.budget_s, bool(job.fit_args), elapsed_s)


class OptimizeJob:
    def __init__(self):
        self.args = []
        self.job_dir = ""
        self.out_dir = ""
        self.object_name = ""
        self.count = 0
        self.matrix = None
        self.mesh_entries = []      # scene "meshes" entries: name + material name
        self.materials = []         # names of the materials to write back
        self.write_environment = True
        self.warnings = []
        self.fit_args = []          # the geometry stage's command line (empty: no fit)
        self.fit_dir = ""
        self.budget_s = 0.0         # a time preset's seconds for the whole run (0: Custom)


def _camera_image(cam_obj):
    """The training image of a camera: custom property 'ptir_image' (object or camera data), else the
    camera's first background image."""
    for holder in (cam_obj, cam_obj.data):
        if "ptir_image" in holder:
            return bpy.path.abspath(str(holder["ptir_image"]))
    for bg in getattr(cam_obj.data, "background_images", []):
        if bg.image is not None and bg.image.source == "FILE":
            return bpy.path.abspath(bg.image.filepath)
    return None


def _image_size(path):
    """(width, height) of an image file, read through a temporary image block (removed again: preparing a
    job must not add data to the file)."""
    try:
        img = bpy.data.images.load(path, check_existing=False)
    except RuntimeError:
        return 0, 0
    try:
        return tuple(img.size)
    finally:
        bpy.data.images.remove(img)


def _camera_views(scene, warnings):
    views = []
    for obj in sorted((o for o in scene.objects if o.type == "CAMERA"), key=lambda o: o.name):
        image = _camera_image(obj)
        if image is None:
            continue
        if obj.data.type != "PERSP":
            warnings.append("camera '%s' is not perspective (skipped)" % obj.name)
            continue
        width, height = _image_size(image)
        if width == 0 or height == 0:
            raise OptimizeError("camera '%s': cannot read image '%s'" % (obj.name, image))
        cam = obj.data
        fov = scene_file.horizontal_fov(cam.lens, cam.sensor_width, cam.sensor_height, cam.sensor_fit, width, height)
        views.append({"name": obj.name, "matrix": np.array(obj.matrix_world, np.float64), "fov_x": fov,
                      "image": image})
    if not views:
        raise OptimizeError("no scene camera has a training image: set a camera's custom property 'ptir_image' "
                            "to the photo's path, or give it a background image")
    return views


def _target_object(context, settings):
    obj = settings.splat_object
    if obj is None:
        active = context.view_layer.objects.active
        obj = active if splat_object.is_splat_object(active) else None
    if obj is None:
        candidates = [o for o in context.scene.objects if splat_object.is_splat_object(o)]
        if len(candidates) == 1:
            obj = candidates[0]
    if obj is None:
        raise OptimizeError("choose the splat object to optimise (panel: Splats)")
    if not splat_object.is_splat_object(obj):
        raise OptimizeError("object '%s' is not a splat object" % obj.name)
    return obj


def _check_views_can_follow(obj, matrix):
    """A dataset's cameras are in the object's local frame and move with it; a pinhole camera can follow a
    rotation, translation and uniform scale, not a non-uniform scale or shear (the photos show the capture
    unstretched), so such an object is refused rather than optimised against views that do not match it."""
    if not splat_transform.is_similarity(matrix):
        raise OptimizeError("object '%s' has a non-uniform scale or shear (axis scales %s): the dataset's photos "
                            "show the capture unstretched and its cameras cannot follow; optimise with a uniform "
                            "scale and stretch the object afterwards, or use Scene Cameras"
                            % (obj.name, ", ".join("%.4g" % s for s in splat_transform.axis_scales(matrix))))


def is_scene_light(obj):
    """Whether a visible object lights the scene for the engine: a point, sun or area lamp with power, or
    a mesh whose material emits (what Environment "None (Scene Lights Only)" optimises under)."""
    if obj.type == "LIGHT":
        return obj.data.type in ("POINT", "SUN", "AREA") and obj.data.energy > 0.0
    if obj.type != "MESH" or splat_object.is_splat_object(obj):
        return False
    return any(max(material_export.material_params(slot.material).get("emission", (0.0,))) > 0.0
               for slot in obj.material_slots if slot.material is not None)


def _has_own_light(doc):
    """Whether an exported scene file has light besides the environment: lamps or emissive meshes."""
    return bool(doc.get("lights")) or any(max(m.get("material", {}).get("emission", [0.0])) > 0.0
                                          for m in doc.get("meshes", []))


def wants_fit(settings, dataset_dir=None, split="train", has_meshes=False):
    """Whether the optimise flow fits the geometry first: ON/OFF as set; AUTO: for a dataset folder in a
    capture layout (COLMAP, nerfstudio, 3DGS output: real photos whose splats a rasteriser trained), and
    for a NeRF-layout folder (synthetic sets: even their own exact splats gain +8 dB of relight fitted,
    README method notes) unless meshes of the scene take part (the photos then show walls and floors the
    fit does not trace: `ptir optimize` skips its own fit there too); not for Scene Cameras."""
    if settings.fit_geometry != "AUTO":
        return settings.fit_geometry == "ON"
    if settings.source != "DATASET" or not dataset_dir:
        return False
    return not (has_meshes and capture_cameras.is_nerf_folder(dataset_dir, split))


def _new_job(context, settings, job_dir, out_dir):
    """The job of the chosen splat object, its splats written in world space: (job, object, PLY path)."""
    job = OptimizeJob()
    job.job_dir = job_dir
    job.out_dir = out_dir or os.path.join(job_dir, "out")
    obj = _target_object(context, settings)
    job.object_name = obj.name
    job.count = len(obj.data.vertices)
    job.matrix = np.array(obj.matrix_world, np.float64)
    # Scene lights only (Environment None): no environment comes back, the World stays as it is.
    job.write_environment = bool(settings.write_environment) and settings.env != "none"
    splats = os.path.join(job_dir, "splats.ply")
    splat_ply.write_splat_ply(splats, splat_object.world_data(obj),
                              comment="PTIR optimisation input: Blender object %s" % obj.name)
    return job, obj, splats


def prepare(context, settings, job_dir, cli_exe, out_dir=None, source=None, own_defaults=False):
    """Writes the inputs and returns an OptimizeJob (raises OptimizeError and the io errors). source
    overrides settings.source; with "SPLATS" (no photos) own_defaults leaves the iterations, samples and
    crops to `ptir optimize`'s own defaults for that path (Make Relightable)."""
    source = source or settings.source
    if source == "SPLATS":
        return _prepare_splats_only(context, settings, job_dir, cli_exe, out_dir, own_defaults)
    job, obj, splats = _new_job(context, settings, job_dir, out_dir)

    split = settings.split.strip() or "train"
    src_dir = bpy.path.abspath(settings.dataset_dir) if settings.source == "DATASET" else ""
    if settings.source == "DATASET" and (not src_dir or not os.path.isdir(src_dir)):
        raise OptimizeError("dataset folder '%s' does not exist" % settings.dataset_dir)
    # Meshes and lights of the scene (without the splats; the environment is what gets recovered).
    scene_json = None
    want_meshes = bool(settings.optimize_meshes)
    try:
        scene_json, info = scene_bridge.export_engine_scene(
            context, os.path.join(job_dir, "scene"), include_splats=False, include_environment=False,
            warnings=job.warnings, allow_empty=True, include_cameras=False)
        job.mesh_entries = info["meshes"]
        with open(scene_json) as f:
            doc = json.load(f)
        own_light = _has_own_light(doc)
        if not doc.get("meshes") and not doc.get("lights"):
            scene_json = None
    except scene_export.ExportError as e:
        raise OptimizeError("scene export: %s" % e)
    if settings.env == "none" and not own_light:
        raise OptimizeError("Environment is None (scene lights only) but no visible lamp or emissive mesh lights "
                            "the scene")
    if want_meshes:
        names = {e["material"].get("name") for e in job.mesh_entries}
        job.materials = sorted(m.name for m in bpy.data.materials
                               if m.name in names and getattr(m, "ptir", None) is not None and m.ptir.optimize)
        if not job.materials:
            raise OptimizeError("Mesh Materials is on but no material of a visible mesh is ticked")
        if scene_json is None:
            raise OptimizeError("Mesh Materials is on but the scene has no meshes")

    # A real capture (COLMAP, nerfstudio, 3DGS output) is read in place, in the object's own frame (the
    # capture's: the artist may have stood it up or moved it), unless meshes of the scene (in world space)
    # take part with the object moved: its masks, EXIF and the capture stage (the splat as an object
    # against the photos' background, the photos' exposure and colours: docs/captures.md) then apply.
    identity = bool(np.allclose(job.matrix, np.eye(4), atol=0.0, rtol=0.0))
    in_place_capture = settings.source == "DATASET" and not capture_cameras.is_nerf_folder(src_dir, split) and \
        (identity or not job.mesh_entries)
    # Views.
    views_dir = os.path.join(job_dir, "views")
    if settings.source == "DATASET":
        transforms = os.path.join(src_dir, "transforms_%s.json" % split)
        if in_place_capture and not identity:
            # The capture's frame is the object's own (its file's, as imported; the artist may have stood it up):
            # its splats go in that frame and the results come back in it.
            splat_ply.write_splat_ply(splats, splat_object.read_data_from_object(obj),
                                      comment="PTIR optimisation input: Blender object %s (its own frame)" % obj.name)
            job.matrix = np.eye(4)
            dataset_dir = src_dir
        elif identity:
            dataset_dir = src_dir  # any layout the engine reads (NeRF, COLMAP, 3DGS output, nerfstudio)
        else:
            _check_views_can_follow(obj, job.matrix)
            if not capture_cameras.is_nerf_folder(src_dir, split):
                # A capture in another layout: its cameras (pinhole, undistorted photos) as a NeRF file to move.
                # Masks and EXIF exposure are not carried by that file.
                transforms = os.path.join(views_dir, "capture_%s.json" % split)
                os.makedirs(views_dir, exist_ok=True)
                capture_cameras.export_cameras(cli_exe, src_dir, transforms, split)
                job.warnings.append("the capture's cameras follow the moved object; its masks and EXIF exposure are "
                                    "not used (optimise with the object at the identity to use them)")
            dataset_file.transform_dataset(transforms, os.path.join(views_dir, "transforms_%s.json" % split),
                                           job.matrix)
            dataset_dir = views_dir
    else:
        dataset_file.write_views(os.path.join(views_dir, "transforms_%s.json" % split),
                                 _camera_views(context.scene, job.warnings))
        dataset_dir = views_dir

    gaussians = splats
    budget = preset_seconds(settings)
    job.budget_s = budget
    if wants_fit(settings, bpy.path.abspath(settings.dataset_dir) if settings.source == "DATASET" else None, split,
                 has_meshes=bool(job.mesh_entries)):
        job.fit_dir = os.path.join(job.out_dir, "fit")
        gaussians = os.path.join(job.fit_dir, "gaussians.ply")
        job.fit_args = engine_client.fit_args(cli_exe, settings, dataset_dir, split, splats, job.fit_dir, budget)
    light = []
    # The World's light, known (known_world.py); with Environment None the scene's lamps are all the light.
    if settings.light != "LEARN" and settings.env != "none":
        light = known_world.light_args(settings, known_world.write_known_world(context.scene, job_dir, job.warnings))
    job.args = engine_client.optimize_args(cli_exe, settings, dataset_dir, split, gaussians, job.out_dir,
                                           bool(job.fit_args), budget, scene_json, want_meshes, light)
    return job


def _prepare_splats_only(context, settings, job_dir, cli_exe, out_dir, own_defaults):
    """`ptir optimize --gaussians splats.ply` without --dataset: the targets are rendered from the splats'
    own radiance (docs/relightable.md). The scene's meshes and lights take no part (the targets show the
    splats alone); no geometry stage (the targets are the splats' own). The splats go out in world space,
    where the artist stood the object up (import Convention, or a rotation): Blender's +Z is their up
    (`--up`), so the virtual views' elevations are measured about the object as it stands."""
    job, _, splats = _new_job(context, settings, job_dir, out_dir)
    job.args = engine_client.splats_only_args(cli_exe, settings, splats, job.out_dir, own_defaults)
    return job


class Results:
    def __init__(self):
        self.object_name = ""
        self.albedo = self.roughness = self.metallic = self.normal = None
        self.splats = None    # after a fit: the fitted splats (SplatData, object space) that replace the object's
        self.count = 0        # the object's splat count when the job was prepared
        self.materials = {}   # material name -> engine material (exported fields + recovered base_color, roughness, metallic)
        self.environment = None  # path of env.exr
        self.pack_environment = False


def _to_local_normals(normal, matrix):
    """World-space normals -> object space (normals map with the inverse transpose; back with its inverse)."""
    a = np.asarray(matrix, np.float64)[:3, :3]
    nrm = normal.astype(np.float64) @ a  # (A^T n)^T = n^T A
    length = np.linalg.norm(nrm, axis=1, keepdims=True)
    zero = length[:, 0] <= 0
    nrm = nrm / np.where(length > 0, length, 1.0)
    nrm[zero] = 0.0
    return nrm.astype(np.float32)


def load_results(job, pack_environment):
    """Reads and checks the optimiser's outputs; changes nothing in Blender."""
    r = Results()
    r.object_name = job.object_name
    ply = os.path.join(job.out_dir, "gaussians.ply")
    if not os.path.isfile(ply):
        raise OptimizeError("the optimiser wrote no %s" % ply)
    d = splat_ply.read_splat_ply(ply)
    r.count = job.count
    if job.fit_args:
        # The optimiser ran on the fitted splats (world space): they become the object's, in its frame.
        fitted = os.path.join(job.fit_dir, "gaussians.ply")
        n_fit = len(splat_ply.read_splat_ply(fitted)) if os.path.isfile(fitted) else -1
        if len(d) != n_fit:
            raise OptimizeError("the optimiser returned %d splats for the %d of the fit (%s)" % (len(d), n_fit, fitted))
        r.splats = splat_transform.transform_splats(d, np.linalg.inv(job.matrix), what="the inverse object transform")
    elif len(d) != job.count:
        raise OptimizeError("the optimiser returned %d splats for the object's %d" % (len(d), job.count))
    r.albedo = np.clip(d.albedo, 0.0, 1.0)
    r.roughness = np.clip(d.roughness, 0.0, 1.0)
    r.metallic = np.clip(d.metallic, 0.0, 1.0)
    r.normal = _to_local_normals(d.normal, job.matrix)
    if job.materials:
        recovered = dataset_file.read_mesh_materials(os.path.join(job.out_dir, "mesh_materials.json"))
        per_material = {}
        for entry in job.mesh_entries:
            mat = entry["material"].get("name")
            if mat in job.materials and entry["name"] in recovered:
                per_material.setdefault(mat, []).append(recovered[entry["name"]])
        exported = {e["material"].get("name"): e["material"] for e in job.mesh_entries}
        for mat, values in per_material.items():
            # What the engine rendered the material with (its model's fields as exported), with the
            # recovered values: written back whole, so that Cycles renders what the engine did.
            r.materials[mat] = {k: v for k, v in exported.get(mat, {}).items() if k not in ("name", "emission")}
            r.materials[mat].update({k: (np.mean([v[k] for v in values], axis=0).tolist() if k == "base_color"
                                         else float(np.mean([v[k] for v in values])))
                                     for k in ("base_color", "roughness", "metallic")})
    if job.write_environment:
        env = os.path.join(job.out_dir, "env.exr")
        if not os.path.isfile(env):
            raise OptimizeError("the optimiser wrote no %s" % env)
        r.environment = env
        r.pack_environment = pack_environment
    return r


def set_world_environment(scene, image_path, pack):
    """The world's Background colour from an Environment Texture of image_path (strength 1, no rotation)."""
    world = scene.world
    if world is None:
        world = bpy.data.worlds.new("World")
        scene.world = world
    tree = compat.ensure_nodes(world)
    nodes, links = tree.nodes, tree.links
    out = next((n for n in nodes if n.type == "OUTPUT_WORLD" and n.is_active_output), None) \
        or next((n for n in nodes if n.type == "OUTPUT_WORLD"), None) or nodes.new("ShaderNodeOutputWorld")
    bg = None
    if out.inputs["Surface"].is_linked and out.inputs["Surface"].links[0].from_node.type == "BACKGROUND":
        bg = out.inputs["Surface"].links[0].from_node
    if bg is None:
        bg = nodes.new("ShaderNodeBackground")
        bg.location = (out.location.x - 250, out.location.y)
        links.new(bg.outputs[0], out.inputs["Surface"])
    bg.inputs["Strength"].default_value = 1.0
    tex = nodes.get(ENV_NODE)
    if tex is None or tex.type != "TEX_ENVIRONMENT":
        tex = nodes.new("ShaderNodeTexEnvironment")
        tex.name = tex.label = ENV_NODE
        tex.location = (bg.location.x - 350, bg.location.y)
    image = bpy.data.images.load(image_path, check_existing=False)
    image.name = "PTIR recovered environment"
    if pack:
        image.pack()
        # The optimiser's temp folder goes away: name the file beside the .blend instead, where
        # File > External Data > Unpack writes it.
        image.filepath_raw = "//ptir_environment.exr"
    tex.image = image
    tex.projection = "EQUIRECTANGULAR"
    for l in list(tex.inputs["Vector"].links):
        links.remove(l)  # the optimiser's environment is in Blender's orientation, unrotated
    links.new(tex.outputs["Color"], bg.inputs["Color"])
    return image


def _replace_splats(obj, r):
    """The object's mesh becomes a new one holding the fitted splats (another count: vertex groups and
    selections of the old splats do not carry over); its materials and the display modifier stay."""
    old = obj.data
    name = old.name
    mesh = bpy.data.meshes.new(name)
    splat_object.write_data_to_mesh(mesh, r.splats)
    for m in old.materials:
        mesh.materials.append(m)
    obj.data = mesh
    for g in list(obj.vertex_groups):
        obj.vertex_groups.remove(g)
    if old.users == 0:
        bpy.data.meshes.remove(old)
        mesh.name = name


def apply_results(context, r):
    """Writes the results into the scene; returns a one-line summary."""
    obj = bpy.data.objects.get(r.object_name)
    if obj is None or not splat_object.is_splat_object(obj) or len(obj.data.vertices) != r.count:
        raise OptimizeError("the splat object '%s' changed during the optimisation; results not applied"
                            % r.object_name)
    was_edit = obj.mode == "EDIT"
    if was_edit:
        bpy.ops.object.mode_set(mode="OBJECT")
    if r.splats is not None:
        _replace_splats(obj, r)
    splat_object.write_material_attributes(obj.data, r.albedo, r.roughness, r.metallic, r.normal)
    obj.data.update()
    if was_edit:
        bpy.ops.object.mode_set(mode="EDIT")
    parts = ["%d splats" % len(r.albedo) + (" (fitted from %d)" % r.count if r.splats is not None else "")]
    for name, p in r.materials.items():
        mat = bpy.data.materials.get(name)
        if mat is None:
            continue
        material_writeback.write_principled(mat, p)
        for key in ("ptir_base_color", "ptir_roughness", "ptir_metallic"):
            if key in mat:  # explicit overrides would hide the recovered values from the exporter
                del mat[key]
    if r.materials:
        parts.append("%d materials" % len(r.materials))
    if r.environment:
        set_world_environment(context.scene, r.environment, r.pack_environment)
        parts.append("environment")
    return ", ".join(parts)
