#include "ptir/optim/exposure.h"

#include <cmath>

namespace ptir {

float ExposureGradients::scale(const Parameters& p, size_t view) {
  const ParameterGroup* g = p.find(ParamKind::Exposure);
  return g && view < g->raw.size() ? std::exp(g->raw[view]) : 1.0f;
}

void ExposureGradients::expose(Image& render, float s) {
  if (s == 1.0f) return;
  const int ch = render.channels;
  for (size_t p = 0; p < render.pixels.size(); p += size_t(ch))
    for (int c = 0; c < 3 && c < ch; ++c) render.pixels[p + c] *= s;
}

void ExposureGradients::accumulate(size_t view, const Image& d_exposed, const Image& exposed) {
  if (view >= d_log_scale.size()) return;
  const size_t n = size_t(exposed.width) * exposed.height;
  double sum = 0.0;
  for (size_t p = 0; p < n; ++p)
    for (int c = 0; c < 3; ++c)
      sum += double(d_exposed.pixels[p * d_exposed.channels + c]) * double(exposed.pixels[p * exposed.channels + c]);
  d_log_scale[view] += sum;
}

std::vector<float> ExposureGradients::raw_gradient() const {
  return std::vector<float>(d_log_scale.begin(), d_log_scale.end());
}

void centre_exposure(ParameterGroup& g) {
  if (g.raw.empty()) return;
  double mean = 0.0;
  for (float x : g.raw) mean += x;
  mean /= double(g.raw.size());
  for (float& x : g.raw) x -= float(mean);
}

}  // namespace ptir
