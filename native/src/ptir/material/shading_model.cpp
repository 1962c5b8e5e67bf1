#include "ptir/material/shading_model.h"

namespace ptir {

const char* to_string(BsdfModel m) { return m == BsdfModel::DisneySimplified ? "disney-simplified" : "principled"; }

std::optional<BsdfModel> parse_bsdf_model(const std::string& name) {
  if (name == "principled") return BsdfModel::Principled;
  if (name == "disney-simplified") return BsdfModel::DisneySimplified;
  return std::nullopt;
}

const char* to_string(SurfaceShader s) {
  switch (s) {
    case SurfaceShader::PrincipledMultiGGX: return "principled-multiscatter";
    case SurfaceShader::Diffuse: return "diffuse";
    default: return "principled";
  }
}

std::optional<SurfaceShader> parse_surface_shader(const std::string& name) {
  if (name == "principled") return SurfaceShader::PrincipledGGX;
  if (name == "principled-multiscatter") return SurfaceShader::PrincipledMultiGGX;
  if (name == "diffuse") return SurfaceShader::Diffuse;
  return std::nullopt;
}

}  // namespace ptir
