// Orienting initial normals toward the cameras that see them (docs/method.md §1).
//
// A trainer's PLY has no normals; the shortest axis is a good normal up to its
// sign. Each camera traces primary rays and every Gaussian of the first surface
// it reaches (while the ray is still more than half transparent) votes with
// its compositing weight T_i alpha_i for the sign that faces that camera. Normals
// with a negative vote are flipped; Gaussians no ray reached fall back to facing
// away from the field's centroid.
#pragma once

#include <vector>

#include "ptir/accel/scene_accel.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/scene.h"

namespace ptir {

struct OrientStats {
  size_t flipped = 0;
  size_t unseen = 0;  // oriented by the centroid fallback
};

// Only normals that did not come from the file are re-oriented (all of them when
// field.normals_from_file is false). rays_per_camera bounds the cost: the image
// grid is subsampled to about that many rays.
// keep_unseen: Gaussians no ray reached keep their sign (else: the centroid fallback).
OrientStats orient_normals_to_cameras(GaussianField& field, const SceneAccel& accel, const std::vector<Camera>& cameras,
                                      int rays_per_camera = 256 * 256, bool keep_unseen = false);

// For a loaded scene: when its Gaussians' normals did not come from their files,
// orients them toward the scene's cameras (meshes occlude), or away from the
// field's centroid when the scene has no camera. About 256K rays in all.
OrientStats orient_scene_normals(Scene& scene);

}  // namespace ptir
