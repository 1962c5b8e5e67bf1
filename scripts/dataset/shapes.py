"""The family's objects (`make_dataset.py --shape NAME`, docs/family.md): built in code from Blender's
primitives (the same in 3.4, 4.5 and 5.0), each part a plain Principled material (scene.py), every
modifier applied so that the polygons the splats are made of are the ones Cycles renders.

What each shape stands for:
    blob        convex: a noise-displaced sphere on a low box
    facets      convex, sharp edges: a low-poly icosahedron (flat faces) on a box plinth
    bowl        concave: an open hemispherical shell (its inside lights itself) on a slab
    monkey_torus concave, occlusion: Suzanne lying in a torus
    rods        thin parts: a thin torus ring held by three thin rods over a slab
    table       thin parts: a slab on four thin legs with a small cube under it
    cluster     several objects, occlusion and interreflection: cubes and a sphere close together on a plate
    pillars     several objects: square pillars of different heights, turned, close together on a plate
    spheres     metals (with --metal-fraction): two touching spheres on a plate
    twisted     a twisted box (Simple Deform) on a plate
    vase        concave lathe (spin of a profile): a vase with an open mouth
    capsules    stacked capsules (rounded cylinders), leaning, on a plate

Parts get distinct base colours (the textures start from them); each call is deterministic.
"""

import math

import bpy
import numpy as np

from . import scene as dscene

# Part colours (linear) and roughness: the textures (textures.py) vary around them.
PALETTE = [(0.70, 0.25, 0.12), (0.15, 0.45, 0.60), (0.55, 0.55, 0.50), (0.20, 0.50, 0.15),
           (0.75, 0.65, 0.20), (0.45, 0.20, 0.55)]


def _material(i):
    c = PALETTE[i % len(PALETTE)]
    return dscene.principled_material("part_%d" % i, c, 0.3 + 0.1 * (i % 4))


def _active(name, mat, smooth=False):
    obj = bpy.context.active_object
    obj.name = name
    obj.data.materials.clear()
    obj.data.materials.append(mat)
    if smooth:
        for p in obj.data.polygons:
            p.use_smooth = True
    return obj


def _subdivide(obj, levels, simple=True):
    """A Subdivision Surface modifier (SIMPLE: cuts only; else Catmull-Clark), applied."""
    if levels <= 0:
        return obj
    mod = obj.modifiers.new("cuts", "SUBSURF")
    mod.subdivision_type = "SIMPLE" if simple else "CATMULL_CLARK"
    mod.levels = mod.render_levels = levels
    _apply(obj)
    return obj


def _apply(obj):
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    for mod in list(obj.modifiers):
        bpy.ops.object.modifier_apply(modifier=mod.name)
    bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)


def _plate(mat, radius=1.2, z=-0.05, height=0.1, cuts=4):
    """A square slab (a box, not a cylinder: an n-gon cap's subdivision makes long kite-shaped polygons
    whose splats stick out past the rim -- measured on the first family, oracle NVS 22.9 dB)."""
    return _box("plate", mat, (1.6 * radius, 1.6 * radius, height), (0, 0, z), cuts=cuts)


def _box(name, mat, size, loc, rot=(0, 0, 0), cuts=4):
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=loc, rotation=rot)
    obj = _active(name, mat)
    obj.scale = size
    return _subdivide(obj, cuts)


def _sphere(name, mat, radius, loc, subdiv=4):
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=subdiv, radius=radius, location=loc)
    obj = _active(name, mat, smooth=True)
    _apply(obj)
    return obj


def _cylinder(name, mat, radius, depth, loc, rot=(0, 0, 0), vertices=32, cuts=2):
    bpy.ops.mesh.primitive_cylinder_add(vertices=vertices, radius=radius, depth=depth, location=loc, rotation=rot)
    return _subdivide(_active(name, mat, smooth=True), cuts)


def _displace(obj, amount, seed):
    """Moves every vertex along its direction from the origin by amount x smooth noise in [-1, 1]."""
    rng = np.random.default_rng(seed)
    co = np.empty(len(obj.data.vertices) * 3)
    obj.data.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    n = np.zeros(len(co))
    for f in (1.5, 3.1):
        for _ in range(4):
            d = rng.normal(size=3)
            n += np.sin(f * (co @ (d / np.linalg.norm(d))) * math.pi + rng.uniform(0, 6.3)) / f
    n /= np.abs(n).max()
    r = np.linalg.norm(co, axis=1, keepdims=True)
    co = co * (1.0 + amount * n[:, None] / np.maximum(r, 1e-9) * r.mean())
    obj.data.vertices.foreach_set("co", co.ravel())
    obj.data.update()


def _lathe(name, mat, profile, steps=48):
    """A surface of revolution about z from a (radius, z) profile: quads between rings, open ends."""
    import bmesh
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    rings = []
    for r, z in profile:
        rings.append([bm.verts.new((r * math.cos(2 * math.pi * k / steps), r * math.sin(2 * math.pi * k / steps), z))
                      for k in range(steps)])
    for a, b in zip(rings[:-1], rings[1:]):
        for k in range(steps):
            bm.faces.new((a[k], a[(k + 1) % steps], b[(k + 1) % steps], b[k]))
    bm.normal_update()
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    mesh.materials.append(mat)
    for p in mesh.polygons:
        p.use_smooth = True
    return obj


def _blob(m):
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=5, radius=0.7, location=(0, 0, 0))
    blob = _active("blob", m[0], smooth=True)
    _displace(blob, 0.25, 7)
    blob.location.z = 0.75
    _apply(blob)
    return [blob, _box("stand", m[1], (1.0, 1.0, 0.3), (0, 0, 0.0))]


def _facets(m):
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=0.8, location=(0, 0, 0.85))
    ico = _subdivide(_active("icosahedron", m[0]), 4)
    return [ico, _box("plinth", m[1], (1.0, 1.0, 0.3), (0, 0, -0.1))]


def _bowl(m):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.9, location=(0, 0, 0.9))
    bowl = _active("bowl", m[0], smooth=True)
    import bmesh
    bm = bmesh.new()
    bm.from_mesh(bowl.data)
    bmesh.ops.delete(bm, geom=[v for v in bm.verts if v.co.z > 0.02], context="VERTS")  # the upper half
    bm.to_mesh(bowl.data)
    bm.free()
    mod = bowl.modifiers.new("shell", "SOLIDIFY")
    mod.thickness = 0.06
    _apply(bowl)
    bowl.rotation_euler = (math.radians(20.0), 0.0, 0.0)
    _apply(bowl)
    _subdivide(bowl, 1)
    return [bowl, _plate(m[1], 1.0, -0.04, 0.08)]


def _monkey_torus(m):
    bpy.ops.mesh.primitive_torus_add(major_radius=1.0, minor_radius=0.3, major_segments=64, minor_segments=24,
                                     location=(0, 0, 0.3))
    torus = _subdivide(_active("torus", m[1], smooth=True), 1)
    bpy.ops.mesh.primitive_monkey_add(size=1.3, location=(0, 0, 0.55), rotation=(math.radians(60), 0, math.radians(15)))
    head = _active("monkey", m[0], smooth=True)
    _subdivide(head, 2, simple=False)
    return [torus, head]


def _rods(m):
    bpy.ops.mesh.primitive_torus_add(major_radius=0.85, minor_radius=0.06, major_segments=96, minor_segments=12,
                                     location=(0, 0, 1.1), rotation=(math.radians(70), 0, 0))
    ring = _subdivide(_active("ring", m[0], smooth=True), 1)
    parts = [ring, _plate(m[1], 0.9)]
    for k in range(3):
        a = 2 * math.pi * k / 3
        parts.append(_cylinder("rod_%d" % k, m[2], 0.04, 1.5, (0.35 * math.cos(a), 0.35 * math.sin(a), 0.75),
                               vertices=12, cuts=2))
    return parts


def _table(m):
    parts = [_box("top", m[0], (1.6, 1.1, 0.08), (0, 0, 0.9)), _box("cube", m[2], (0.5, 0.5, 0.5), (0.1, 0, 0.25))]
    for k, (x, y) in enumerate(((0.7, 0.45), (-0.7, 0.45), (0.7, -0.45), (-0.7, -0.45))):
        parts.append(_cylinder("leg_%d" % k, m[1], 0.04, 0.86, (x, y, 0.43), vertices=12, cuts=2))
    return parts


def _cluster(m):
    return [_plate(m[3], 1.3),
            _box("cube_a", m[0], (0.7, 0.7, 0.7), (-0.35, 0.2, 0.35), (0, 0, 0.3)),
            _box("cube_b", m[1], (0.45, 0.45, 0.9), (0.45, 0.35, 0.45), (0, 0, -0.4)),
            _sphere("ball", m[2], 0.35, (0.15, -0.45, 0.35)),
            _box("cube_c", m[4], (0.35, 0.35, 0.35), (-0.5, -0.55, 0.175), (0, 0, 0.8))]


def _pillars(m):
    parts = [_plate(m[3], 1.25)]
    spots = [(-0.45, -0.3, 1.4), (0.2, -0.45, 0.9), (0.55, 0.25, 1.2), (-0.15, 0.45, 0.6), (0.0, 0.0, 0.4)]
    for k, (x, y, h) in enumerate(spots):
        parts.append(_box("pillar_%d" % k, m[k % 3], (0.36, 0.36, h), (x, y, 0.5 * h), (0, 0, 0.4 * k)))
    return parts


def _spheres(m):
    return [_plate(m[2], 1.2), _sphere("sphere_a", m[0], 0.55, (-0.4, 0.1, 0.55)),
            _sphere("sphere_b", m[1], 0.4, (0.5, -0.1, 0.4))]


def _twisted(m):
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 0.8))
    box = _active("twisted", m[0])
    box.scale = (0.7, 0.7, 1.6)
    _apply(box)
    _subdivide(box, 4)
    mod = box.modifiers.new("twist", "SIMPLE_DEFORM")
    mod.deform_method = "TWIST"
    mod.angle = math.radians(90.0)
    mod.deform_axis = "Z"
    _apply(box)
    return [box, _plate(m[1], 1.0)]


def _vase(m):
    profile = [(0.35, 0.0), (0.6, 0.25), (0.75, 0.6), (0.65, 1.0), (0.35, 1.3), (0.3, 1.5), (0.42, 1.65), (0.36, 1.68),
               (0.25, 1.55), (0.25, 1.3)]
    vase = _lathe("vase", m[0], profile)
    _subdivide(vase, 2)
    return [vase, _plate(m[1], 0.8, -0.04, 0.08)]


def _capsules(m):
    parts = [_plate(m[3], 1.2)]
    for k, (x, y, tilt) in enumerate(((-0.4, 0.0, 20.0), (0.35, 0.2, -15.0), (0.0, -0.45, 35.0))):
        bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=0.28, location=(0, 0, 0))
        cap = _active("capsule_%d" % k, m[k])
        import bmesh
        bm = bmesh.new()
        bm.from_mesh(cap.data)
        for v in bm.verts:  # stretch the sphere's halves apart: a capsule of length 1.1
            v.co.z += 0.4 if v.co.z > 0 else -0.4
        long = [e for e in bm.edges if abs(e.verts[0].co.z - e.verts[1].co.z) > 0.3]
        bmesh.ops.subdivide_edges(bm, edges=long, cuts=7, use_grid_fill=True)  # the stretched band in 8 rings
        bm.to_mesh(cap.data)
        bm.free()
        for p in cap.data.polygons:
            p.use_smooth = True
        cap.rotation_euler = (math.radians(tilt), math.radians(0.5 * tilt), 0.0)
        cap.location = (x, y, 0.7)
        _apply(cap)
        _subdivide(cap, 1)
        parts.append(cap)
    return parts


SHAPES = {"blob": _blob, "facets": _facets, "bowl": _bowl, "monkey_torus": _monkey_torus, "rods": _rods,
          "table": _table, "cluster": _cluster, "pillars": _pillars, "spheres": _spheres, "twisted": _twisted,
          "vase": _vase, "capsules": _capsules}


def build_shape(name, radius=1.25):
    """The shape `name` (SHAPES), in collection PTIR_Object, scaled into a sphere of `radius` about the
    origin. Returns its mesh objects."""
    mats = [_material(i) for i in range(5)]
    objs = SHAPES[name](mats)
    coll = dscene._collection()
    for o in objs:
        dscene._move_to(o, coll)
    dscene.normalise_objects(objs, radius)
    bpy.ops.object.select_all(action="SELECT")
    bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)
    bpy.ops.object.select_all(action="DESELECT")
    return objs
