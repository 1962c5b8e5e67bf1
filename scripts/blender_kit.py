"""The Blender helpers that scripts, tests and benchmarks share: one copy of each.

Import it with scripts/ on sys.path (`import blender_kit as kit`). The numpy-only part
works in plain Python as well; the rest needs Blender's bpy (imported when present).

Plain Python:
    look_at(eye, target, up)            camera-to-world 4x4 (Blender / NeRF: looks down -z, +y up)
    run_main(main, prog)                a script's entry point: traceback and exit status 1 on error
                                        (blender -b would otherwise exit 0 after a traceback)
Blender:
    reset_scene(...)                    no objects, lights, meshes, cameras, materials; black world
    plain_cycles(scene, ...)            Cycles without anything that changes the estimator's
                                        expectation (no denoising, adaptive sampling or clamping)
    match_estimator(scene, bounces)     ... and the settings that make it compute what PTIR's path
                                        tracer computes (bounce limits, no glossy filter or light
                                        culling, caustics, 1-px box filter)
    exr_output(scene)                   render output: linear 32-bit float EXR (RGB, ZIP)
    add_camera(...), add_light(...)     objects aimed / placed as given
    add_pedestal(...)                   the sample object's box pedestal (top / side materials, grid faces)
    separate_suzanne(...)               the active Suzanne split into head and eyes, materials, subdivision
    set_environment(scene, path, ...)   world = Environment Texture (Closest), optional Mapping
                                        Z rotation, strength
    write_rgbe_texels(path, w, h, f)    a Radiance .hdr from a texel function (the add-on's writer)
    render_still(scene, path, seed)     F12 to a file; read_pixels(path) reads an image back, linear
    world_polygons(obj, depsgraph)      the evaluated mesh's world-space polygons, the input of the
                                        add-on's surface-splat builder (io/surface_splats.py)
"""

import argparse
import os
import sys
import time
import traceback

import numpy as np

try:
    import bpy
except ImportError:  # plain Python: the numpy-only helpers
    bpy = None

# Scene-linear Rec.709 as Blender names it: "Linear" in 3.x, "Linear Rec.709" from 4.0 on.
LINEAR = "Linear Rec.709" if bpy is not None and bpy.app.version >= (4, 0, 0) else "Linear"

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ADDON_PARENT = os.path.join(REPO, "addon")
if ADDON_PARENT not in sys.path:
    sys.path.insert(0, ADDON_PARENT)


# ---------------------------------------------------------------- plain Python

def look_at(eye, target=(0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0)):
    """Camera-to-world 4x4 (float64) at eye looking at target: the camera looks down its -z, +y up
    (Blender's and NeRF's convention), with world `up` (default +z)."""
    eye, target, up = (np.asarray(x, np.float64) for x in (eye, target, up))
    back = eye - target
    back /= np.linalg.norm(back)
    right = np.cross(up, back)
    right /= np.linalg.norm(right)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, np.cross(back, right), back, eye
    return m


def scene_script_args(samples=256, seeds=None, extra=None):
    """The arguments after `--` of a comparison-scene script: --out-dir, --res (128), --samples,
    --bounces (2), --threads (2), --seeds when given a default list; extra(parser) adds the script's own."""
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser()
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--samples", type=int, default=samples)
    if seeds is not None:
        ap.add_argument("--seeds", type=int, nargs="+", default=list(seeds))
    ap.add_argument("--bounces", type=int, default=2)
    ap.add_argument("--threads", type=int, default=2)
    if extra:
        extra(ap)
    return ap.parse_args(argv)


def run_main(main, prog=None):
    """Runs main(); on an exception prints the traceback (and "prog: error: ...") and exits 1."""
    try:
        main()
    except Exception as e:
        traceback.print_exc()
        if prog:
            print("%s: error: %s" % (prog, e), file=sys.stderr)
        sys.exit(1)


# ---------------------------------------------------------------- scene

def reset_scene(images=False):
    """Removes every object, light, mesh, camera and material (and image when asked); the world
    becomes a black Background of strength 0. Returns the scene."""
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob, do_unlink=True)
    blocks = [bpy.data.lights, bpy.data.meshes, bpy.data.cameras, bpy.data.materials]
    for coll in blocks + ([bpy.data.images] if images else []):
        for block in list(coll):
            coll.remove(block)
    scene = bpy.context.scene
    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    nt = _world_tree(world)
    nt.nodes.clear()
    bg = nt.nodes.new("ShaderNodeBackground")
    out = nt.nodes.new("ShaderNodeOutputWorld")
    bg.inputs["Color"].default_value = (0, 0, 0, 1)
    bg.inputs["Strength"].default_value = 0.0
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    return scene


def add_camera(scene, location, direction, fov_x=None, ortho_scale=None, name="camera"):
    """A perspective camera (horizontal field of view fov_x, radians) or, with ortho_scale, an
    orthographic one, at location looking along direction (up: +y of the image toward world +z, or
    toward +x when looking straight up or down); it becomes the scene camera."""
    from mathutils import Vector
    data = bpy.data.cameras.new(name)
    if ortho_scale is not None:
        data.type = "ORTHO"
        data.ortho_scale = ortho_scale
    else:
        data.type = "PERSP"
        data.sensor_fit = "HORIZONTAL"
        data.angle = fov_x
    data.clip_start = 0.01
    data.clip_end = 1000.0
    cam = bpy.data.objects.new(name, data)
    scene.collection.objects.link(cam)
    cam.location = location
    up = "Y" if abs(Vector(direction).normalized().z) < 0.999 else "X"
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = Vector(direction).to_track_quat("-Z", up)
    scene.camera = cam
    return cam


def add_light(scene, kind, energy, location=(0, 0, 0), rotation=(0, 0, 0), **props):
    """A white light of the kind (POINT, SUN, AREA, SPOT) with energy (W, or W/m^2 for a sun) and the
    light-data properties given (shape, size, shadow_soft_size, angle, ...)."""
    data = bpy.data.lights.new(kind.lower(), kind)
    data.energy = energy
    data.color = (1, 1, 1)
    for k, v in props.items():
        setattr(data, k, v)
    ob = bpy.data.objects.new(kind.lower(), data)
    scene.collection.objects.link(ob)
    ob.location = location
    ob.rotation_euler = rotation
    return ob


def add_pedestal(size, height, z, top_material, side_material, cuts, open_bottom=False):
    """A size x size x height box centred at (0, 0, z), named "pedestal": material 0 (top_material)
    on the top face, 1 (side_material) on the others, the bottom face removed with open_bottom; a
    SIMPLE subdivision of `cuts` levels (uniform cuts: square faces on top). Returns the object."""
    import bmesh
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, z))
    obj = bpy.context.active_object
    obj.name = "pedestal"
    obj.scale = (size, size, height)
    bpy.ops.object.transform_apply(scale=True)
    obj.data.materials.append(top_material)
    obj.data.materials.append(side_material)
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    if open_bottom:
        bmesh.ops.delete(bm, geom=[f for f in bm.faces if f.normal.z < -0.9], context="FACES")
    for f in bm.faces:
        f.material_index = 0 if f.normal.z > 0.9 else 1
    bm.to_mesh(obj.data)
    bm.free()
    mod = obj.modifiers.new("grid", "SUBSURF")
    mod.subdivision_type = "SIMPLE"
    mod.levels = mod.render_levels = cuts
    return obj


def separate_suzanne(material_of, subdiv, smooth_shading=False):
    """Splits the active Suzanne into its loose parts, "head" (the largest) and "eye_1", "eye_2":
    each gets material_of("head") or material_of("eyes") and a Catmull-Clark subdivision of
    `subdiv` levels (and smooth shading with smooth_shading). Returns the parts, head first."""
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.separate(type="LOOSE")
    bpy.ops.object.mode_set(mode="OBJECT")
    parts = sorted(bpy.context.selected_objects, key=lambda o: len(o.data.vertices), reverse=True)
    for i, obj in enumerate(parts):
        obj.name = "head" if i == 0 else "eye_%d" % i
        obj.data.materials.clear()
        obj.data.materials.append(material_of("head" if i == 0 else "eyes"))
        if smooth_shading:
            for poly in obj.data.polygons:
                poly.use_smooth = True
        mod = obj.modifiers.new("smooth", "SUBSURF")
        mod.levels = mod.render_levels = subdiv
    return parts


def _world_tree(world):
    """The world's node tree, in use (5.0 deprecates World.use_nodes: always on)."""
    from ptir_blender.blender import compat
    return compat.ensure_nodes(world)


def set_world_colour(scene, colour, strength=1.0):
    """World = a Background node of that colour and strength (every Blender; 5.0 has no node-less worlds)."""
    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    nt = _world_tree(world)
    nt.nodes.clear()
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Color"].default_value = (*colour[:3], 1.0)
    bg.inputs["Strength"].default_value = strength
    out = nt.nodes.new("ShaderNodeOutputWorld")
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    return world


def set_environment(scene, path, rotation_z=None, strength=1.0, sampling="MANUAL", linear=True):
    """World = Environment Texture of the image file (equirectangular, Closest interpolation = PTIR's
    nearest lookup) x strength. rotation_z: a Mapping node (Point, Z rotation, radians) in front of it;
    None: no Mapping node. sampling: Cycles' world importance sampling (MANUAL: a 256 map; NONE; None:
    left as it is). linear: the image's colour space set to Linear."""
    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    _world_tree(world)
    if sampling is not None:
        world.cycles.sampling_method = sampling
        if sampling == "MANUAL":
            world.cycles.sample_map_resolution = 256
    nt = world.node_tree
    nt.nodes.clear()
    if rotation_z is not None:
        texco = nt.nodes.new("ShaderNodeTexCoord")
        mapping = nt.nodes.new("ShaderNodeMapping")
        mapping.vector_type = "POINT"
        mapping.inputs["Rotation"].default_value = (0.0, 0.0, rotation_z)
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.interpolation = "Closest"
    env.projection = "EQUIRECTANGULAR"
    env.image = bpy.data.images.load(os.path.abspath(path), check_existing=True)
    if linear:
        env.image.colorspace_settings.name = LINEAR
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = strength
    out = nt.nodes.new("ShaderNodeOutputWorld")
    if rotation_z is not None:
        nt.links.new(texco.outputs["Generated"], mapping.inputs["Vector"])
        nt.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    return env


def write_rgbe_texels(path, width, height, texel):
    """A flat Radiance .hdr whose texel (col, row) -- row 0 = the file's top row -- is texel(col, row)
    (linear RGB), written by the add-on's RGBE writer. (Blender 3.4's Image.save() would write a
    generated float image display-encoded.)"""
    from ptir_blender.io import hdr_file
    rgb = np.array([[texel(col, row) for col in range(width)] for row in range(height)], np.float64)
    return hdr_file.write_rgbe(path, rgb)


# ---------------------------------------------------------------- Cycles

def plain_cycles(scene, res, samples, threads=0, transparent=False, compositing=False):
    """Cycles on the CPU with nothing that changes the estimator's expectation: no denoising, no adaptive
    sampling, no clamping; res x res pixels (square), threads (0: Blender's automatic count), Standard
    view transform (linear outputs stay linear), film transparent or not, compositor on or off."""
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = samples
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    scene.render.threads_mode = "FIXED" if threads > 0 else "AUTO"
    if threads > 0:
        scene.render.threads = threads
    scene.render.resolution_x = res
    scene.render.resolution_y = res
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0
    scene.render.film_transparent = transparent
    scene.render.use_compositing = compositing
    scene.render.use_sequencer = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0


def match_estimator(scene, bounces):
    """The Cycles settings that make it compute the expectation PTIR's path tracer computes: every bounce
    limit = bounces (no volumes), no glossy filter (it blurs indirect glossy), no light culling
    (threshold 0), caustics on (PTIR does not filter them), a Box pixel filter of 1 px (= PTIR's uniform
    jitter in the pixel), a fixed seed pattern."""
    cy = scene.cycles
    cy.max_bounces = bounces
    cy.diffuse_bounces = bounces
    cy.glossy_bounces = bounces
    cy.transmission_bounces = bounces
    cy.volume_bounces = 0
    cy.transparent_max_bounces = 8
    cy.blur_glossy = 0.0
    cy.light_sampling_threshold = 0.0
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    cy.use_animated_seed = False


def exr_output(scene):
    """The render output: linear 32-bit float OpenEXR, RGB, ZIP."""
    st = scene.render.image_settings
    st.file_format = "OPEN_EXR"
    st.color_mode = "RGB"
    st.color_depth = "32"
    st.exr_codec = "ZIP"


def render_still(scene, path, seed=None):
    """Renders the scene to path (its output format); returns the seconds taken."""
    if seed is not None:
        scene.cycles.seed = seed
    scene.render.filepath = path
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    return time.time() - t0


def read_pixels(path, linear=True):
    """The pixels of an image file as float32 (height, width, channels), rows bottom-up (Blender's
    order), read by Blender (colour space scene-linear unless linear=False); the image is not kept."""
    img = bpy.data.images.load(path, check_existing=False)
    try:
        if linear:
            img.colorspace_settings.name = LINEAR
        w, h, ch = img.size[0], img.size[1], img.channels
        px = np.empty(w * h * ch, np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    return px.reshape(h, w, ch)


# ---------------------------------------------------------------- meshes

def world_polygons(obj, depsgraph):
    """The evaluated (modifiers applied) mesh of obj in world space, polygon by polygon: loop positions
    (L, 3) float64 in polygon order, each polygon's first loop (n,) and corner count (n,), and its
    material index (n,) -- what io/surface_splats.polygons_to_gaussians takes."""
    ev = obj.evaluated_get(depsgraph)
    mesh = ev.to_mesh()
    co = np.empty(len(mesh.vertices) * 3, np.float64)
    mesh.vertices.foreach_get("co", co)
    m = np.array(obj.matrix_world)
    co = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    n_poly = len(mesh.polygons)
    start = np.empty(n_poly, np.int64)
    total = np.empty(n_poly, np.int64)
    mat = np.empty(n_poly, np.int64)
    mesh.polygons.foreach_get("loop_start", start)
    mesh.polygons.foreach_get("loop_total", total)
    mesh.polygons.foreach_get("material_index", mat)
    loop_vert = np.empty(len(mesh.loops), np.int64)
    mesh.loops.foreach_get("vertex_index", loop_vert)
    ev.to_mesh_clear()
    order = np.argsort(start)
    start, total, mat = start[order], total[order], mat[order]
    # Loops in polygon order, so reduceat over the starts sums per polygon.
    idx = np.concatenate([np.arange(s, s + t) for s, t in zip(start, total)]) if n_poly else np.zeros(0, np.int64)
    loops = co[loop_vert[idx]]
    new_start = np.concatenate([[0], np.cumsum(total)[:-1]]) if n_poly else start
    return loops, new_start, total, mat
