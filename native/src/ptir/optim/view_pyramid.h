// The resolution pyramid of the training views (issue 38): the first part of
// an inversion renders every view reduced by a power of two, the rest at the
// photos' own resolution.
//
// Why: an iteration's cost grows with the pixels it renders, but the unknowns
// (one albedo and roughness per Gaussian, the light) do not. While the
// parameters are far from their values the gradient's direction is what
// matters, and a view reduced to a quarter of its pixels gives it over the
// whole object at a quarter of the cost; the full-resolution phase then
// resolves what only the photos' own pixels show (texture finer than a coarse
// pixel, silhouettes).
//
// A reduced view: pixel (x, y) covers the f x f full pixels [f x, f x + f) x
// [f y, f y + f); the image keeps floor(W / f) x floor(H / f) pixels (the
// remainder's columns and rows are not trained on at that level). Its target is
// the box average of those pixels, of the associated (alpha-weighted) colour
// for images with alpha, so an edge pixel is the object's colour over its
// coverage, as the full image's are; its camera has fx, fy, cx, cy divided by
// f. The render keeps its pixel filter in its own (coarse) pixels: the
// target's footprint is the full filter convolved with an f-pixel box, about
// one coarse pixel wider than the full filter's -- a blur the full-resolution
// phase removes.
#pragma once

#include "ptir/io/image.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/dataset.h"
#include "ptir/scene/view_reduce.h"

namespace ptir {

// The smallest power-of-two factor f that brings a width x height view to at
// most max_pixels pixels (1 when it already has; max_pixels <= 0: always 1).
int pyramid_factor(int width, int height, int max_pixels);

// reduce_camera, reduce_image and reduce_training_image: scene/view_reduce.h.

}  // namespace ptir
