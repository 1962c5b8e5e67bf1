// Reading and writing Gaussian fields as 3DGS PLY files.
//
// Input: the INRIA 3DGS layout (x,y,z, scale_0..2 as log, rot_0..3 as w,x,y,z,
// opacity as logit, f_dc_0..2, f_rest_* of any SH degree or none), properties
// found by name in any order, any numeric type; optional PTIR material
// properties albedo_0..2, roughness, metallic, nx,ny,nz (activated, linear).
// 2D Gaussian Splatting's layout (the same with scale_0 and scale_1 only: surfels
// in the rotation's x-y plane, normal along its z axis) is read as flat Gaussians
// whose third scale is kSurfelThickness x the smaller of the two; written back, the
// file keeps its own two scale columns.
// SuperSplat's compressed PLY (chunk + packed vertex elements) is decoded to
// the same values. Anything else is refused with an error naming the file and
// what is missing or wrong.
#pragma once

#include <string>

#include "ptir/scene/gaussians.h"

namespace ptir {

// A 2DGS surfel's thickness, as a share of its smaller scale: so thin that it renders
// as the disc it is (Blender 5.3 clamps splat scales at 1e-3 of the largest), and the
// smallest of the three however elongated the surfel, so its shortest axis -- the
// normal the engine takes -- is the surfel's own normal.
inline constexpr float kSurfelThickness = 1e-3f;

// Loads and activates a Gaussian field. Normals: from nx,ny,nz when present and
// non-zero, else the shortest axis (normals_from_file = false).
// Throws ptir::Error("<path>: <problem>") for bad input.
GaussianField load_gaussians(const std::string& path);

// Builds a field from an already-read PLY (path only for messages).
GaussianField gaussians_from_ply(io::PlyFile ply, const std::string& path);

// Writes the field: every property of field.source unchanged (same names, types,
// values) plus albedo_0..2, roughness, metallic, nx,ny,nz overwritten or added as
// float. A field without a source (built in code) is written in the standard
// INRIA layout. Atomic (temp file + rename).
void save_gaussians(const std::string& path, const GaussianField& field);

}  // namespace ptir
