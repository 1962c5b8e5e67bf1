// Renders of a recovered asset for evaluation and relighting: object-only
// (transparent film) path tracing, the albedo scale of the evaluation protocol,
// and command-line light specifications.
#pragma once

#include <array>
#include <string>

#include "ptir/core/render_control.h"
#include "ptir/io/image.h"
#include "ptir/lights/emitters.h"
#include "ptir/scene/gaussians.h"
#include "ptir/transport/path_tracer.h"

namespace ptir::eval {

// Path-traced RGBA with a transparent film, like Cycles' Film > Transparent:
// samples whose camera ray escapes (sees the environment directly) contribute
// nothing to RGB and count as uncovered; RGB is premultiplied by coverage
// (EXR's associated alpha) and A is the fraction of samples that hit a surface.
// Lighting from the environment, lights and meshes is unchanged. Camera jitter and
// paths use the same keys as render_path, so covered pixels match it exactly.
Image render_transparent(const PathTracer& tracer, const Camera& camera, const IntegratorSettings& settings,
                         const RenderControl& control = {}, PathStats* stats = nullptr);

// Multiplies every Gaussian's albedo by s (per channel), clamped to [0, 1]:
// the protocol's "materials rescaled by the albedo scale before relighting".
void scale_albedo(GaussianField& field, const std::array<double, 3>& s);

// Parses a point light "x,y,z,watts[,r,g,b[,radius]]" (Blender units: Power in W,
// Radius in m) into PointLight::from_blender. Throws Error naming `spec`.
PointLight parse_point_light(const std::string& spec);

// Parses an area light "cx,cy,cz,tx,ty,tz,size_x,size_y,watts[,r,g,b]": a
// rectangle centred at c facing the target point t (emits toward it), with
// Blender's Size X / Size Y and Power (AreaLight::from_blender). The light's local
// x axis is horizontal (perpendicular to world z and the facing direction).
AreaLight parse_area_light(const std::string& spec);

}  // namespace ptir::eval
