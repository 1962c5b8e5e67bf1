// How `ptir eval` reads a real capture's result (docs/captures.md): the photos as the run
// read them, and the object's pixels from the capture stage's coverage masks.
#pragma once

#include <string>

#include "ptir/io/image.h"
#include "ptir/scene/dataset.h"

namespace ptir::eval {

// Where RESULT/capture/calibration.json left the EXIF exposure out, every view's exposure
// becomes 1 (the photos as stored, as the run read them). The per-photo gains are not
// applied: the render as it is against the photo as stored. Nothing without the file.
void read_photos_as_the_run_did(Dataset& data, const std::string& result);

// A real capture's object in view `name`: the capture stage's coverage mask
// (RESULT/capture/masks/<name>.png, the input splat's coverage > 0.5) as a 1-channel 0/1
// image, or an empty image where the result has none. A mask of another size than the
// photo fails naming the file.
Image capture_object_mask(const std::string& result, const std::string& name, int width, int height);

}  // namespace ptir::eval
