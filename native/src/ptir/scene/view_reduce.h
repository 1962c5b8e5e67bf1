// A view reduced by an integer factor f: pixel (x, y) covers the f x f full
// pixels [f x, f x + f) x [f y, f y + f); the image keeps floor(W / f) x
// floor(H / f) pixels (the remainder's columns and rows are dropped, which moves
// no pixel centre: x_reduced = x_full / f exactly). Its camera has fx, fy, cx, cy
// divided by f. Used by the resolution pyramid (optim/view_pyramid.h) and by the
// capture loader's working size (--max-image-side, scene/dataset.h).
#pragma once

#include "ptir/io/image.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/dataset.h"

namespace ptir {

// The camera of the view reduced by f (see the top). f = 1: the same camera.
// The camera must not be cropped (throws ptir::Error naming it otherwise).
Camera reduce_camera(const Camera& cam, int f);

// Box average of f x f pixels, every channel as it is (maps: albedo, roughness).
Image reduce_image(const Image& img, int f);

// A training image reduced by f: colour averaged with the alpha as weight
// (straight colour of the average; the plain average where the coarse pixel's
// alpha is 0), alpha averaged.
TrainingImage reduce_training_image(const TrainingImage& t, int f);

}  // namespace ptir
