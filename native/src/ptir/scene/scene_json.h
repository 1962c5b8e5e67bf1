// The scene file: a JSON description of Gaussians, meshes with materials,
// lights, environment, cameras and integrator settings (docs/scene_format.md).
//
// Lights use Blender's units and are converted exactly as Cycles does
// (PointLight/SunLight/AreaLight::from_blender); the lat-long environment uses
// Blender's orientation. Relative file paths resolve against the folder of the
// JSON file (or the base_dir given with a string). Unknown keys are errors, so a
// typo never silently falls back to a default. Every error is a ptir::Error
// naming the file and the JSON path, e.g.
//   "scene.json: lights[2].power must be a number".
#pragma once

#include <array>
#include <string>

#include "ptir/math/vec.h"
#include "ptir/scene/scene.h"

namespace ptir {

// Reads a scene file. Gaussians whose PLY has no normals keep their shortest
// axes unoriented: renderers call orient_scene_normals (transport layer) next.
Scene load_scene_json(const std::string& path);

// The same from JSON text; relative paths resolve against base_dir ("" = the
// current folder); `name` stands for the file in messages.
Scene scene_from_json_string(const std::string& text, const std::string& base_dir, const std::string& name = "scene");

// A mesh material from the JSON text of a scene file's "material" object (the
// same rules and messages as in a meshes entry); `name` stands for the text in
// messages and is the material's default name. For edits of a loaded scene.
MeshMaterial mesh_material_from_json_string(const std::string& text, const std::string& name);

// Applies a row-major 4x4 affine transform to a Gaussian field in place:
// positions, rotations, scales and normals. The linear part must be a rotation
// (mirrors allowed) times a uniform scale; anything else (non-uniform scale,
// shear, a projective last row) throws Error(what, ...). Higher-order SH
// coefficients (preview colour only) are not rotated. The field's source PLY is
// dropped (its positions would be stale), so a later save writes the standard layout.
void transform_gaussians(GaussianField& field, const float m[16], const std::string& what);

// Appends `b` to `a` (SH degrees padded to the larger one; the source PLY is
// dropped unless `a` was empty).
void append_gaussians(GaussianField& a, GaussianField&& b);

// Unit quaternion (w, x, y, z), w >= 0, of a rotation matrix.
std::array<float, 4> mat3_to_quat(const Mat3& r);

}  // namespace ptir
