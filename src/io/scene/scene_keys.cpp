#include "io/scene/scene_keys.hpp"

#include "io/scene/builder.hpp"

#include <algorithm>
#include <stdexcept>

#include "qbond/integrators/integrators.hpp"

namespace qbond::scene_detail {
namespace {

// "enum:a|b|c": what a key holds that takes one of these names.
template <class Names>
std::string enum_of(const Names& names) {
  std::string s = "enum:";
  for (std::string_view n : names) {
    if (s.size() > 5) s += '|';
    s += n;
  }
  return s;
}

std::vector<std::string_view> integrator_keys() {
  std::vector<std::string_view> keys;
  for (const IntegratorInfo& i : integrator_table()) keys.push_back(i.key);
  return keys;
}

std::vector<SceneObject> make_table() {
  std::vector<SceneObject> t = {
      {"scene",
       "a scene file",
       {{"name", "string"},
        {"description", "string"},
        {"seed", "integer"},
        {"timestep", "number"},
        {"steps", "integer"},
        {"duration", "number"},
        {"gravity", "vec3"},
        {"integrator", "@integrator"},
        {"adaptive", "@adaptive"},
        {"limits", "@limits"},
        {"materials", "{@material}"},
        {"bodies", "[@body]"},
        {"bonds", "[@bond]"},
        {"anchors", "[@anchor]"},
        {"loads", "[@load]"},
        {"heuristics", "[@heuristic]"},
        {"output", "@output"},
        {"camera", "@camera"}}},
      {"camera",
       "how `qbond view` looks at the scene (runs ignore it)",
       {{"position", "vec3"}, {"target", "vec3"}, {"fov", "number"}}},
      {"adaptive",
       "error-controlled steps",
       {{"error", "number"},
        {"energy", "number"},
        {"min_step", "number"},
        {"max_step", "number"},
        {"safety", "number"}}},
      {"limits",
       "blow-up and energy-gain detection",
       {{"max_speed", "number"}, {"energy_growth", "number"}, {"energy_gain", "number"}, {"stop_on_energy_gain", "boolean"}}},
      {"rotation", "a rotation by `angle` [rad] about `axis`", {{"axis", "vec3"}, {"angle", "number"}}},
      {"selection",
       "quanta chosen by every criterion given",
       {{"ids", "array"},
        {"body", "string"},
        {"box", "array"},
        {"sphere", "@sphere"},
        {"half_space", "@half_space"},
        {"all", "boolean"}}},
      {"sphere", "a ball", {{"center", "vec3"}, {"radius", "number"}}},
      {"half_space", "the side of a plane the normal points to", {{"point", "vec3"}, {"normal", "vec3"}}},
      {"bond.between",
       "one bond between two quanta",
       {{"between", "array"}, {"body", "string"}, {"material", "string"}, {"rest_length", "number"}}},
      {"bond.within",
       "bonds between two selections' quanta closer than `within`",
       {{"from", "@selection"},
        {"to", "@selection"},
        {"within", "number"},
        {"material", "string"},
        {"rest_length", "number"}}},
      {"anchor", "quanta held or moved on a path", {{"select", "@selection"}, {"motion", "@motion"}}},
      {"motion",
       "one of fixed, translate, rotate",
       {{"fixed", "@motion.fixed"},
        {"translate", "@motion.translate"},
        {"rotate", "@motion.rotate"},
        {"keyframes", "@motion.keyframes"}}},
      {"motion.fixed", "held where it is", {}},
      {"motion.translate", "moved at a constant velocity", {{"velocity", "vec3"}}},
      {"motion.rotate", "turned about an axis", {{"axis", "vec3"}, {"center", "vec3"}, {"rate", "number"}}},
      {"motion.keyframes",
       "poses at given times, interpolated, the last one held",
       {{"frames", "[@keyframe]"},
        {"axis", "vec3"},
        {"center", "vec3"},
        {"interpolation", "enum:linear|smooth"}}},
      {"keyframe",
       "a pose: rotated by `angle` about the motion's axis through its center, then shifted by `offset`",
       {{"time", "number"}, {"offset", "vec3"}, {"angle", "number"}}},
      {"load",
       "a constant total force spread over the selection",
       {{"select", "@selection"}, {"force", "vec3"}}},
      {"output",
       "what a run writes",
       {{"dir", "string"},
        {"every", "integer"},
        {"vtk", "boolean"},
        {"checkpoint_every", "integer"},
        {"probes", "[@probe]"}}},
      {"probe",
       "a named selection measured at every output step",
       {{"name", "string"}, {"select", "@selection"}, {"about", "vec3"}}},
  };
  // Body and heuristic types: their tables' rows (bodies.cpp, heuristics.cpp).
  for (const Builder::BodyReader& r : Builder::body_readers())
    t.push_back({"body." + std::string(r.type), r.doc, r.keys});
  for (const HeuristicReader& r : Builder::heuristic_readers())
    t.push_back({"heuristic." + std::string(r.type), r.doc, r.keys});
  // The integrator's keys are its table's options (integrators.hpp).
  SceneObject integrator{
      "integrator", "the step integrator and its options", {{"type", enum_of(integrator_keys())}}};
  for (const IntegratorOptionInfo& opt : integrator_options()) {
    std::string holds;
    switch (opt.holds) {
      case IntegratorOptionInfo::Holds::integer: holds = "integer"; break;
      case IntegratorOptionInfo::Holds::number: holds = "number"; break;
      case IntegratorOptionInfo::Holds::boolean: holds = "boolean"; break;
      case IntegratorOptionInfo::Holds::name: holds = enum_of(opt.names()); break;
    }
    integrator.keys.push_back({std::string(opt.key), holds});
  }
  t.push_back(std::move(integrator));
  // Materials, by law (laws/registry.hpp).
  for (const LawInfo& law : all_laws()) {
    SceneObject m{"material." + std::string(law.name), std::string(law.doc), {}};
    for (const std::string& k : material_keys(law))
      m.keys.push_back({k, k == "law" ? "string" : k == "damping_model" ? "enum:axial|isotropic" : "number"});
    t.push_back(std::move(m));
  }
  return t;
}

}  // namespace

std::vector<std::string> material_keys(const LawInfo& law) {
  std::vector<std::string> keys = {"law", "density", "damping", "damping_model",
                                   std::string(law.strength.key)};
  if (law.calibrated_by_modulus) keys.emplace_back("youngs_modulus");
  for (const LawParam& p : law.shape) keys.emplace_back(p.key);
  return keys;
}

const std::vector<SceneObject>& scene_objects() {
  static const std::vector<SceneObject> table = make_table();
  return table;
}

bool has_kind(std::string_view kind) {
  const auto& t = scene_objects();
  return std::any_of(t.begin(), t.end(), [&](const SceneObject& o) { return o.kind == kind; });
}

std::vector<const char*> keys_of(std::string_view kind) {
  for (const SceneObject& o : scene_objects())
    if (o.kind == kind) {
      std::vector<const char*> keys;
      for (const SceneKey& k : o.keys) keys.push_back(k.name.c_str());
      return keys;
    }
  throw std::logic_error("scene_keys: no kind '" + std::string(kind) + "'");
}

}  // namespace qbond::scene_detail
