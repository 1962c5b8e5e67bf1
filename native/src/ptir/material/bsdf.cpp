#include "ptir/material/bsdf.h"

namespace ptir {

const char* to_string(BsdfModel m) { return m == BsdfModel::DisneySimplified ? "disney-simplified" : "principled"; }

std::optional<BsdfModel> parse_bsdf_model(const std::string& name) {
  if (name == "principled") return BsdfModel::Principled;
  if (name == "disney-simplified" || name == "disney") return BsdfModel::DisneySimplified;
  return std::nullopt;
}

const char* to_string(SurfaceShader s) {
  switch (s) {
    case SurfaceShader::PrincipledMultiGGX: return "principled-multiscatter";
    case SurfaceShader::Diffuse: return "diffuse";
    default: return "principled";
  }
}

}  // namespace ptir
