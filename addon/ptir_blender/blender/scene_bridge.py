"""The whole Blender scene -> an engine scene folder (scene.json + PLYs + images).

scene_export.export_scene (meshes, lights, world, cameras; another module) does
everything except the splat objects; this module adds them: each visible splat
object is written as a 3DGS PLY in world space (its transform folded into
positions, scales, rotations and normals by the PLY exporter) and listed under
"gaussians" without a transform.

    path, info = export_engine_scene(context, "/tmp/job", integrator={"spp": 32})
    path, info = export_engine_scene(out_dir=..., depsgraph=render_depsgraph)   # in RenderEngine.render
"""

import json
import os
import types

from ..io import scene_file, splat_ply
from . import scene_export, splat_object


class _RenderLayer:
    """A view layer stand-in for scene_export inside RenderEngine.render(): it evaluates objects with the
    render depsgraph and does not trigger a depsgraph update from the render thread."""

    def __init__(self, depsgraph):
        self.depsgraph = depsgraph
        # The render depsgraph holds what renders (collection exclusion and render visibility applied).
        self.objects = {o.original.name for o in depsgraph.objects}

    def update(self):
        pass


def _visible(scene, view_layer_objects):
    for obj in scene.objects:
        if obj.hide_render:
            continue
        if view_layer_objects is not None and obj.name not in view_layer_objects:
            continue
        yield obj


def export_engine_scene(context=None, out_dir=None, integrator=None, warnings=None, depsgraph=None,
                        include_splats=True, include_environment=True, splat_filter=None, scene_name="scene.json",
                        allow_empty=False, include_cameras=True):
    """Writes the scene folder; returns (scene.json path, info dict).

    context: bpy.context (scene + view layer); or pass depsgraph (a render depsgraph) instead.
    include_splats: add the visible splat objects (False: the scene without them, e.g. for the optimiser,
    which takes its splats separately). splat_filter: only these splat objects. allow_empty: no error
    when nothing renderable is left.
    info: {"splats": [(object name, PLY path, count)], "meshes": [scene "meshes" entries], "warnings": [...]}.
    """
    warnings = [] if warnings is None else warnings
    os.makedirs(out_dir, exist_ok=True)
    if depsgraph is not None:
        scene = depsgraph.scene
        layer = _RenderLayer(depsgraph)
        source = types.SimpleNamespace(scene=scene, view_layer=layer)
        layer_objects = layer.objects
    else:
        scene = context.scene
        source = context
        layer_objects = context.view_layer.objects
    visible = list(_visible(scene, layer_objects))
    splats = [o for o in visible if splat_object.is_splat_object(o)]
    others = [o for o in visible if not splat_object.is_splat_object(o)]
    path = scene_export.export_scene(source, out_dir, scene_name=scene_name, integrator=integrator, objects=others,
                                     warnings=warnings, include_cameras=include_cameras)
    with open(path) as f:
        doc = json.load(f)
    if not include_environment:
        doc.pop("environment", None)
    info = {"splats": [], "meshes": list(doc.get("meshes", [])), "warnings": warnings}
    if include_splats:
        entries = list(doc.get("gaussians", []))
        used = set()
        for obj in splats:
            if splat_filter is not None and obj not in splat_filter:
                continue
            d = splat_object.world_data(obj, sync_edit_mode=depsgraph is None)
            base = "splats_%s" % "".join(c if (c.isalnum() or c in "-_.") else "_" for c in obj.name)
            fname, k = base + ".ply", 1
            while fname in used:
                fname, k = "%s_%d.ply" % (base, k), k + 1
            used.add(fname)
            ply = os.path.join(out_dir, fname)
            splat_ply.write_splat_ply(ply, d, comment="PTIR export of Blender object %s" % obj.name)
            entries.append({"file": fname})
            info["splats"].append((obj.name, ply, len(d)))
        if entries:
            doc["gaussians"] = entries
    else:
        doc.pop("gaussians", None)
    if not allow_empty and not doc.get("gaussians") and not doc.get("meshes"):
        raise scene_export.ExportError("nothing to render: the scene has no visible splat or mesh objects")
    scene_file.write_scene(path, doc)
    return path, info


def scene_camera_name(scene):
    cam = scene.camera
    if cam is None or cam.type != "CAMERA":
        raise scene_export.ExportError("the scene has no active camera")
    if cam.data.type != "PERSP":
        raise scene_export.ExportError("camera '%s' is %s; the engine renders perspective cameras only"
                                       % (cam.name, cam.data.type.lower()))
    return cam.name

