#include "ptir/scene/view_reduce.h"

#include "ptir/core/error.h"

namespace ptir {

Camera reduce_camera(const Camera& cam, int f) {
  if (f == 1) return cam;
  if (f < 1) throw Error(cam.name, "reduction factor must be at least 1");
  if (cam.full_width > 0 || cam.full_height > 0) throw Error(cam.name, "a cropped camera cannot be reduced");
  Camera c = cam;
  c.width = cam.width / f;
  c.height = cam.height / f;
  if (c.width < 1 || c.height < 1) throw Error(cam.name, "reduced by " + std::to_string(f) + " the image is empty");
  const float s = 1.0f / float(f);
  c.fx = cam.fx * s;
  c.fy = cam.fy * s;
  c.cx = cam.cx * s;
  c.cy = cam.cy * s;
  return c;
}

Image reduce_image(const Image& img, int f) {
  if (f == 1) return img;
  const int w = img.width / f, h = img.height / f, C = img.channels;
  Image out(w, h, img.channel_names);
  const float inv = 1.0f / float(f * f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < C; ++c) {
        float s = 0.0f;
        for (int j = 0; j < f; ++j)
          for (int i = 0; i < f; ++i) s += img.at(x * f + i, y * f + j, c);
        out.at(x, y, c) = s * inv;
      }
  return out;
}

TrainingImage reduce_training_image(const TrainingImage& t, int f) {
  if (f == 1) return t;
  TrainingImage r;
  r.has_alpha = t.has_alpha;
  r.alpha = reduce_image(t.alpha, f);
  if (!t.has_alpha) {
    r.rgb = reduce_image(t.rgb, f);
    return r;
  }
  const int w = t.rgb.width / f, h = t.rgb.height / f;
  r.rgb = Image(w, h, t.rgb.channel_names);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      // Associated colour over the block, then back to straight by the block's alpha.
      float assoc[3] = {0, 0, 0}, plain[3] = {0, 0, 0}, a = 0.0f;
      for (int j = 0; j < f; ++j)
        for (int i = 0; i < f; ++i) {
          const float ap = t.alpha.at(x * f + i, y * f + j, 0);
          a += ap;
          for (int c = 0; c < 3; ++c) {
            const float v = t.rgb.at(x * f + i, y * f + j, c);
            assoc[c] += ap * v;
            plain[c] += v;
          }
        }
      for (int c = 0; c < 3; ++c) r.rgb.at(x, y, c) = a > 0.0f ? assoc[c] / a : plain[c] / float(f * f);
    }
  return r;
}

}  // namespace ptir
