#include "ptir/material/shading_model.h"

namespace ptir {

const char* to_string(BsdfModel m) {
  switch (m) {
    case BsdfModel::PrincipledV2: return "principled-v2";
    case BsdfModel::DisneySimplified: return "disney-simplified";
    default: return "principled-v1";
  }
}

std::optional<BsdfModel> parse_bsdf_model(const std::string& name) {
  if (name == "principled-v1" || name == "principled") return BsdfModel::PrincipledV1;
  if (name == "principled-v2") return BsdfModel::PrincipledV2;
  if (name == "disney-simplified") return BsdfModel::DisneySimplified;
  return std::nullopt;
}

const char* bsdf_model_names() { return "principled-v1, principled-v2, disney-simplified (principled = v1)"; }

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
