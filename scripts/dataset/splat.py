"""Mesh surface -> flat 3D Gaussians in the standard (INRIA) 3DGS PLY layout.

One Gaussian per polygon of the evaluated (modifiers applied) mesh, built by the
add-on's surface-splat builder (addon/ptir_blender/io/surface_splats.py, from
blender_kit.world_polygons): centred on the polygon, local z = its normal, in-plane
sigmas 0.6 x its extents (neighbours overlap into an opaque shell), normal sigma
1e-3 x the in-plane one (a flat disc, what trainers converge to on surfaces);
degenerate polygons make none. Stored as trainers store them: log scales, w,x,y,z
quaternion, logit opacity, degree-3 SH (f_dc = display colour, f_rest = 0),
nx,ny,nz = 0 (no normals).

The "oracle" file adds what a perfect inversion would recover -- albedo_0..2
(linear base colour), roughness, metallic and the outward face normal nx,ny,nz --
so the evaluation can be checked on a result with known answers.
"""

import blender_kit as kit
from ptir_blender.io import surface_splats

OPACITY = 0.95

world_polygons = kit.world_polygons


def polygons_to_gaussians(loops, start, total):
    """(Gaussians of the non-degenerate polygons, mask of those polygons) -- see surface_splats."""
    g = surface_splats.polygons_to_gaussians(loops, start, total, skip_degenerate=True)
    return g, g.pop("keep")


def write_gaussians_ply(path, g, oracle=False):
    """INRIA 3DGS layout (binary little-endian float32). g: position, scale, rotation,
    display_colour (sRGB-ish, for the SH preview); with oracle=True also albedo,
    roughness, metallic and normal."""
    comment = "PTIR dataset maker: flat Gaussians from the mesh surface%s" % (
        " + ground-truth materials (oracle)" if oracle else "")
    material = {"albedo": g["albedo"], "roughness": g["roughness"], "metallic": g["metallic"]} if oracle else {}
    surface_splats.write_gaussians_ply(path, g, opacity=OPACITY, write_normals=oracle,
                                       display_colour=g["display_colour"], comment=comment, **material)
