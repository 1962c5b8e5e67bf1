"""Textured materials for the dataset maker (`make_dataset.py --textured`): noise
patterns in base colour and roughness (and optionally metallic patches), stored
per polygon as face attributes that each Principled BSDF reads through Attribute
nodes.

Why per polygon: the dataset's splats are one Gaussian per polygon, so a pattern
that is constant on each polygon is exactly what a perfect inversion can recover
-- the oracle stays exact (every Gaussian takes its polygon's values), while the
images show a texture at the mesh's resolution (the sample at subdivision 2 has
~8K polygons over the object, a few pixels each at 128^2).

The pattern: smooth 3D noise (a sum of random-direction sinusoids at three
frequencies, deterministic for a seed) at each polygon's centre in world space.
    base colour = lerp(material colour, its complement-ish second colour, n1), in [0.03, 0.95]
    roughness   = 0.1 + 0.8 n2                                  (linear, in [0.1, 0.9])
    metallic    = 1 on the metal_fraction of polygons with the largest n3, else 0 (patches; none by default);
                  metal_layout "regions": the largest values of one low-frequency noise instead (a few large
                  parts per object with smooth borders; the patches are a few polygons, i.e. a few splats,
                  across, so the splats' blur at their borders alone held the oracle to 18-20 dB albedo)
"""

import bpy
import numpy as np

ALBEDO = "ptir_albedo"
ROUGHNESS = "ptir_roughness"
METALLIC = "ptir_metallic"


def noise3(points, seed, frequencies=(1.3, 2.9, 6.1), waves=6, clip=True):
    """Smooth noise in [0, 1] at (N, 3) points: random-direction sinusoids, amplitude 1/f (clip=False:
    not clipped, so without ties at 0 and 1 for a quantile to split)."""
    rng = np.random.default_rng(seed)
    total = np.zeros(len(points))
    norm = 0.0
    for f in frequencies:
        for _ in range(waves):
            d = rng.normal(size=3)
            d /= np.linalg.norm(d)
            total += np.sin(f * np.pi * (points @ d) + rng.uniform(0, 2 * np.pi)) / f
            norm += 1.0 / f
    v = total / np.sqrt(norm * 0.5 * waves)  # roughly unit variance
    return np.clip(0.5 + 0.4 * v, 0.0, 1.0) if clip else 0.5 + 0.4 * v


def _second_colour(c):
    """A contrasting colour for the pattern: the channels rotated and lightened."""
    c = np.asarray(c, np.float64)
    return np.clip(0.25 + 0.7 * c[[2, 0, 1]], 0.05, 0.9)


def apply_modifiers(obj):
    bpy.context.view_layer.objects.active = obj
    for mod in list(obj.modifiers):
        bpy.ops.object.modifier_apply(modifier=mod.name)


def polygon_centres(obj):
    me = obj.data
    c = np.empty(len(me.polygons) * 3)
    me.polygons.foreach_get("center", c)
    m = np.array(obj.matrix_world)
    return c.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]


KINDS = ("smooth", "edges", "hifreq", "perface")
METAL_LAYOUTS = ("patches", "regions")


CELLS = 24


def _voronoi_cells(points, seed, cells=CELLS):
    """The index of the nearest of `cells` random sites (in the points' bounding box) of every point."""
    rng = np.random.default_rng(seed)
    lo, hi = points.min(0), points.max(0)
    sites = lo + (hi - lo) * rng.uniform(size=(cells, 3))
    return np.argmin(((points[:, None, :] - sites[None]) ** 2).sum(-1), axis=1)


def pattern(pts, kind, seed):
    """(n1, n2, n3) in [0, 1] per polygon centre for a texture kind (docs/family.md):
    smooth   the smooth noise (three low frequencies)
    edges    the smooth noise thresholded: two tones with sharp boundaries
    hifreq   noise at four times the frequencies (a few polygons per period)
    perface  piecewise constant on 24 random Voronoi cells (random values per cell, sharp boundaries)"""
    if kind == "perface":
        rng = np.random.default_rng(seed + 5)
        cell = _voronoi_cells(pts, seed)
        vals = rng.uniform(size=(3, CELLS))
        return (cell / (CELLS - 1.0),) + tuple(v[cell] for v in vals[1:])
    freq = (5.3, 11.9, 23.7) if kind == "hifreq" else (1.3, 2.9, 6.1)
    n = [noise3(pts, seed + 17 * k, freq) for k in range(3)]
    if kind == "edges":
        n[0] = (n[0] > np.median(n[0])).astype(np.float64)
        n[1] = 0.25 + 0.5 * (n[1] > np.median(n[1]))
    return tuple(n)


def texture_objects(objs, material_values, seed=1, metal_fraction=0.0, kind="smooth", roughness_range=(0.1, 0.9),
                    neutral=False, metal_layout="patches"):
    """Bakes the pattern (`kind`, KINDS) into face attributes of every object (modifiers applied first)
    and rewires every material to read them. material_values(mat) -> (colour, ...). Roughness spans
    roughness_range; with neutral, every albedo is grey (its colour's mean)."""
    if kind not in KINDS:
        raise ValueError("unknown texture kind '%s' (one of %s)" % (kind, ", ".join(KINDS)))
    lo, hi = roughness_range
    for i, obj in enumerate(objs):
        apply_modifiers(obj)
        me = obj.data
        pts = polygon_centres(obj)
        n1, n2, n3 = pattern(pts, kind, seed * 1000 + i)  # (the smooth kind: the seeds of before)
        mat_idx = np.empty(len(me.polygons), np.int64)
        me.polygons.foreach_get("material_index", mat_idx)
        mats = [s.material for s in obj.material_slots] or [None]
        base = np.array([material_values(m)[0] for m in mats], np.float64)[np.clip(mat_idx, 0, len(mats) - 1)]
        second = np.array([_second_colour(material_values(m)[0]) for m in mats])[np.clip(mat_idx, 0, len(mats) - 1)]
        if kind == "perface":  # a random colour per cell, its own palette
            palette = np.random.default_rng(seed * 1000 + i + 9).uniform(0.05, 0.85, size=(CELLS, 3))
            base = second = palette[np.rint(n1 * (CELLS - 1)).astype(int)]
        albedo = np.clip(base + (second - base) * n1[:, None], 0.03, 0.95)
        if neutral:
            albedo = np.repeat(albedo.mean(1, keepdims=True), 3, axis=1)
        rough = lo + (hi - lo) * n2
        # The top metal_fraction of the third pattern: patches of the asked share of polygons.
        if metal_layout not in METAL_LAYOUTS:
            raise ValueError("unknown metal layout '%s' (one of %s)" % (metal_layout, ", ".join(METAL_LAYOUTS)))
        if metal_layout == "regions":  # one wave pair at a period about the object's size
            n3 = noise3(pts, seed * 1000 + i + 31, frequencies=(0.6,), waves=2, clip=False)  # (clipped: ties)
        metal = (n3 > np.quantile(n3, 1.0 - metal_fraction)).astype(np.float64) if metal_fraction > 0 else np.zeros(len(n3))
        for name in (ALBEDO, ROUGHNESS, METALLIC):
            if name in me.attributes:
                me.attributes.remove(me.attributes[name])
        me.attributes.new(ALBEDO, "FLOAT_COLOR", "FACE").data.foreach_set(
            "color", np.concatenate([albedo, np.ones((len(albedo), 1))], 1).ravel().astype(np.float32))
        me.attributes.new(ROUGHNESS, "FLOAT", "FACE").data.foreach_set("value", rough.astype(np.float32))
        me.attributes.new(METALLIC, "FLOAT", "FACE").data.foreach_set("value", metal.astype(np.float32))
    done = set()
    for obj in objs:
        for s in obj.material_slots:
            if s.material and s.material.name not in done:
                _wire(s.material)
                done.add(s.material.name)


def _wire(mat):
    """Principled Base Color / Roughness / Metallic (and the ground-truth AOVs) from the face attributes."""
    nt = mat.node_tree
    p = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")

    def attribute(name):
        node = nt.nodes.new("ShaderNodeAttribute")
        node.attribute_type = "GEOMETRY"
        node.attribute_name = name
        return node

    nt.links.new(attribute(ALBEDO).outputs["Color"], p.inputs["Base Color"])
    nt.links.new(attribute(ROUGHNESS).outputs["Fac"], p.inputs["Roughness"])
    nt.links.new(attribute(METALLIC).outputs["Fac"], p.inputs["Metallic"])
    from . import scene
    scene.ensure_aovs(mat)  # the ground-truth AOVs follow the new links
    for key in ("ptir_base_color", "ptir_roughness", "ptir_metallic"):
        if key in mat:
            del mat[key]
    mat["ptir_face_textured"] = True


def polygon_materials(obj):
    """(albedo (n, 3), roughness (n,), metallic (n,)) per polygon in loop-start order
    (blender_kit.world_polygons' order), or None when obj carries no pattern."""
    me = obj.data
    if ALBEDO not in me.attributes:
        return None
    n = len(me.polygons)
    col = np.empty(n * 4, np.float32)
    me.attributes[ALBEDO].data.foreach_get("color", col)
    rough = np.empty(n, np.float32)
    me.attributes[ROUGHNESS].data.foreach_get("value", rough)
    metal = np.empty(n, np.float32)
    me.attributes[METALLIC].data.foreach_get("value", metal)
    start = np.empty(n, np.int64)
    me.polygons.foreach_get("loop_start", start)
    order = np.argsort(start)
    return col.reshape(-1, 4)[order, :3].astype(np.float64), rough[order].astype(np.float64), metal[order].astype(np.float64)
