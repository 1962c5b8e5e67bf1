#include "ptir/scene/render_settings.h"

#include "ptir/core/error.h"

namespace ptir {

const char* interaction_mode_name(InteractionMode m) { return m == InteractionMode::Discrete ? "discrete" : "aggregate"; }

InteractionMode parse_interaction_mode(const std::string& name, const std::string& what) {
  for (InteractionMode m : {InteractionMode::Aggregate, InteractionMode::Discrete})
    if (name == interaction_mode_name(m)) return m;
  throw Error(what + " must be 'aggregate' or 'discrete', got '" + name + "'");
}

const char* self_intersection_name(SelfIntersection s) { return s == SelfIntersection::FixedOffset ? "fixed" : "backface"; }

SelfIntersection parse_self_intersection(const std::string& name, const std::string& what) {
  for (SelfIntersection s : {SelfIntersection::BackfaceAware, SelfIntersection::FixedOffset})
    if (name == self_intersection_name(s)) return s;
  throw Error(what + " must be 'backface' or 'fixed', got '" + name + "'");
}

const char* light_selection_name(LightSelection s) { return s == LightSelection::All ? "all" : "one"; }

LightSelection parse_light_selection(const std::string& name, const std::string& what) {
  for (LightSelection s : {LightSelection::One, LightSelection::All})
    if (name == light_selection_name(s)) return s;
  throw Error(what + " must be 'one' or 'all', got '" + name + "'");
}

}  // namespace ptir
