// Builder: the scene's top level and its scene-wide sections (integrator, adaptive, limits).
#include "io/scene/builder.hpp"

#include <cmath>
#include <stdexcept>
#include <thread>

#include "qbond/io/memory.hpp"

#include "qbond/model/ordering.hpp"

namespace qbond::scene_detail {

std::uint64_t pair_key(Index a, Index b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}

Builder::Builder(const json& root, std::string default_name, SceneFiles files)
    : root_(root), default_name_(std::move(default_name)), files_(std::move(files)) {}

void Builder::renumber_for_locality(Scene& s) {
  const Renumbering r = locality_order(s.world);
  renumber(s.world, r);
  for (ProbeSpec& p : s.output.probes) {
    renumber_quanta(p.quanta, r);
    std::sort(p.quanta.begin(), p.quanta.end());
  }
  for (HeuristicSpec& h : s.heuristics)
    std::visit([&](auto& rule) {
      if constexpr (requires { rule.quanta; })  // a per-quanta mask, empty when the rule has no select
        if (!rule.quanta.empty()) permute(rule.quanta, r.quanta);
    }, h);
}

Scene Builder::build() {
  Scene s;
  json res = root_;
  Obj top(root_, "", keys_of("scene"));
  s.name = top.has("name") ? string(top["name"], "name") : default_name_;
  s.description = top.has("description") ? string(top["description"], "description") : "";
  s.seed = top.has("seed") ? integer(top["seed"], "seed", 0) : 1;
  s.timestep = positive(top.required("timestep"), "timestep");
  if (top.one_of("steps", "duration")) {
    s.steps = integer(top["steps"], "steps", 0);
    if (s.steps > kMaxSteps) bad("steps", "must be <= 2^53 (" + std::to_string(kMaxSteps) + "), got " + std::to_string(s.steps));
  } else {
    const double d = positive(top["duration"], "duration");
    try {
      s.steps = steps_for_duration(d, s.timestep);
    } catch (const std::invalid_argument& e) {
      bad("duration", e.what());
    }
  }
  World& w = s.world;
  w.model.gravity = top.has("gravity") ? vec3(top["gravity"], "gravity") : Vec3::Zero();
  w.state.rng = Rng{s.seed};
  s.integrator = integrator(top.has("integrator") ? top["integrator"] : json::object());
  integrator_ = s.integrator;
  s.limits = limits(top.has("limits") ? top["limits"] : json::object());
  if (top.has("camera")) s.camera = camera(top["camera"]);
  if (top.has("adaptive")) s.adaptive = adaptive(top["adaptive"], s.timestep, static_cast<double>(s.steps) * s.timestep);
  if (top.has("materials")) materials(top["materials"], res["materials"]);
  bodies(top.required("bodies"), res["bodies"], w);
  if (top.has("bonds")) bonds(array(top["bonds"], "bonds"), w);
  check_overlaps(w);
  if (top.has("anchors")) anchors(array(top["anchors"], "anchors"), w);
  if (top.has("loads")) loads(array(top["loads"], "loads"), w);
  if (top.has("heuristics")) s.heuristics = heuristics(array(top["heuristics"], "heuristics"), w);
  w.state.obstacle_impulse.assign(obstacles_, ObstacleImpulse{});
  check_memory("", static_cast<double>(w.num_quanta()), static_cast<double>(w.num_bonds()));
  s.output = output(top.has("output") ? top["output"] : json::object(), s.steps, w);
  renumber_for_locality(s);

  res["name"] = s.name;
  res["description"] = s.description;
  res["seed"] = s.seed;
  res["steps"] = s.steps;
  res.erase("duration");
  res["gravity"] = {w.model.gravity.x(), w.model.gravity.y(), w.model.gravity.z()};
  const IntegratorConfig& c = s.integrator;
  json& ri = res["integrator"] = {{"type", to_string(c.type)}};
  for (const IntegratorOptionInfo& opt : integrator_options()) {
    json& v = ri[std::string(opt.key)];
    switch (opt.holds) {
      case IntegratorOptionInfo::Holds::integer: v = c.*opt.integer; break;
      case IntegratorOptionInfo::Holds::number: v = c.*opt.number; break;
      case IntegratorOptionInfo::Holds::boolean: v = c.*opt.boolean; break;
      case IntegratorOptionInfo::Holds::name: v = opt.name_of(c); break;
    }
  }
  res["limits"] = {{"max_speed", s.limits.max_speed},
                   {"energy_growth", s.limits.energy_growth},
                   {"energy_gain", s.limits.energy_gain},
                   {"stop_on_energy_gain", s.limits.stop_on_energy_gain}};
  if (s.adaptive.enabled)
    res["adaptive"] = {{"error", s.adaptive.error},       {"energy", s.adaptive.energy},
                       {"min_step", s.adaptive.min_step}, {"max_step", s.adaptive.max_step},
                       {"safety", s.adaptive.safety}};
  json& out = res["output"];
  if (!out.is_object()) out = json::object();
  out["dir"] = s.output.dir;
  out["every"] = s.output.every;
  out["vtk"] = s.output.vtk;
  out["checkpoint_every"] = s.output.checkpoint_every;
  s.resolved = std::move(res);
  return s;
}

void Builder::plan_memory(const std::string& path, double quanta, double bonds) {
  planned_quanta_ += quanta;
  planned_bonds_ += bonds;
  check_memory(path, planned_quanta_, planned_bonds_);
}

std::uint64_t Builder::memory_limit() const {
  return files_.max_memory > 0 ? files_.max_memory : default_memory_limit();
}

std::size_t Builder::bonds_left() const {
  const double base = static_cast<double>(estimated_run_memory(planned_quanta_, planned_bonds_));
  const double per_bond = static_cast<double>(estimated_run_memory(0, 1e6) - estimated_run_memory(0, 0)) / 1e6;
  const double left = (static_cast<double>(memory_limit()) - base) / per_bond;
  return left <= 0 ? 0 : left >= 1e15 ? std::size_t{1'000'000'000'000'000} : static_cast<std::size_t>(left);
}

void Builder::check_memory(const std::string& path, double quanta, double bonds) const {
  const bool given = files_.max_memory > 0;
  const std::uint64_t limit = memory_limit();
  const std::uint64_t need = estimated_run_memory(quanta, bonds);
  if (need <= limit) return;
  bad(path, "would need about " + format_bytes(static_cast<double>(need)) + " of memory (" + num_str(quanta) +
                " quanta, " + num_str(bonds) + " bonds), more than the limit of " +
                format_bytes(static_cast<double>(limit)) +
                (given ? " (--max-memory)" : " (3/4 of this machine's memory; --max-memory sets another)"));
}

IntegratorConfig Builder::integrator(const json& j) {
  // The keys are the integrator table's options (integrators.hpp, through scene_keys); an option
  // the chosen integrator does not read is accepted and ignored, as resolved scenes list every
  // option.
  Obj o(j, "integrator", keys_of("integrator"));
  IntegratorConfig c = default_integrator();
  auto parse = [&](const char* key, auto fn, auto& field) {
    if (!o.has(key)) return;
    try {
      field = fn(string(o[key], o.at(key)));
    } catch (const std::invalid_argument& e) {
      bad(o.at(key), e.what());
    }
  };
  parse("type", parse_integrator_type, c.type);
  for (const IntegratorOptionInfo& opt : integrator_options()) {
    const std::string key(opt.key);
    if (!o.has(key.c_str())) continue;
    const json& v = o[key.c_str()];
    const std::string at = o.at(key);
    switch (opt.holds) {
      case IntegratorOptionInfo::Holds::integer: {
        const std::uint64_t n = integer(v, at, opt.least);
        const std::uint64_t most = opt.most ? static_cast<std::uint64_t>(opt.most())
                                            : static_cast<std::uint64_t>(std::numeric_limits<int>::max());
        if (n > most) {
          std::string rule = "must be <= ";
          rule += opt.most_text ? opt.most_text() : std::to_string(most);
          rule += ", got ";
          rule += std::to_string(n);
          bad(at, rule);
        }
        c.*opt.integer = static_cast<int>(n);
        break;
      }
      case IntegratorOptionInfo::Holds::number: {
        const double x = opt.positive ? positive(v, at) : non_negative(v, at);
        if (!(x < opt.below)) {
          std::string rule = "must be < ";
          rule += num_str(opt.below);
          rule += ", got ";
          rule += num_str(x);
          bad(at, rule);
        }
        c.*opt.number = x;
        break;
      }
      case IntegratorOptionInfo::Holds::boolean: c.*opt.boolean = boolean(v, at); break;
      case IntegratorOptionInfo::Holds::name:
        try {
          opt.set_name(c, string(v, at));
        } catch (const std::invalid_argument& e) {
          bad(at, e.what());
        }
        break;
    }
  }
  const IntegratorInfo& info = integrator_info(c.type);
  auto takes = [&](const char* key, IntegratorOption option, auto list, auto value) {
    if (!o.has(key) || !info.reads(option) || std::find(list.begin(), list.end(), value) != list.end()) return;
    std::string names;
    for (auto v : list) names += (names.empty() ? "" : ", ") + std::string(to_string(v));
    bad(o.at(key), std::string(info.key) + " takes " + names + ", not '" + std::string(to_string(value)) + "'");
  };
  takes("solver", IntegratorOption::solver, info.solvers, c.solver);
  takes("warm_start", IntegratorOption::warm_start, info.warm_starts, c.warm_start);
  return c;
}

AdaptiveConfig Builder::adaptive(const json& j, double timestep, double horizon) {
  Obj o(j, "adaptive", keys_of("adaptive"));
  AdaptiveConfig a;
  a.enabled = true;
  a.horizon = horizon;
  if (o.has("error")) a.error = positive(o["error"], o.at("error"));
  if (o.has("energy")) a.energy = positive(o["energy"], o.at("energy"));
  if (o.has("min_step")) a.min_step = positive(o["min_step"], o.at("min_step"));
  if (o.has("max_step")) a.max_step = non_negative(o["max_step"], o.at("max_step"));
  if (o.has("safety")) {
    a.safety = positive(o["safety"], o.at("safety"));
    if (a.safety >= 1) bad(o.at("safety"), "must be < 1, got " + num_str(a.safety));
  }
  if (a.min_step > timestep) bad(o.at("min_step"), "must be <= timestep (" + num_str(timestep) + "), got " + num_str(a.min_step));
  if (a.max_step > 0 && a.max_step < timestep)
    bad(o.at("max_step"), "must be >= timestep (" + num_str(timestep) + ") or 0, got " + num_str(a.max_step));
  return a;
}

BlowupLimits Builder::limits(const json& j) {
  Obj o(j, "limits", keys_of("limits"));
  BlowupLimits l;
  if (o.has("max_speed")) l.max_speed = positive(o["max_speed"], o.at("max_speed"));
  if (o.has("energy_growth")) l.energy_growth = positive(o["energy_growth"], o.at("energy_growth"));
  if (o.has("energy_gain")) l.energy_gain = positive(o["energy_gain"], o.at("energy_gain"));
  if (o.has("stop_on_energy_gain"))
    l.stop_on_energy_gain = boolean(o["stop_on_energy_gain"], o.at("stop_on_energy_gain"));
  return l;
}

CameraSpec Builder::camera(const json& j) {
  Obj o(j, "camera", keys_of("camera"));
  CameraSpec c;
  if (o.has("position") != o.has("target"))
    bad(o.has("position") ? o.at("position") : o.at("target"), "position and target go together: give both or neither");
  if (o.has("position")) {
    c.position = vec3(o["position"], o.at("position"));
    c.target = vec3(o["target"], o.at("target"));
    if (const std::string p = camera_problem(*c.position, *c.target); !p.empty()) bad(o.at("position"), p);
  }
  if (o.has("fov")) {
    c.fov = positive(o["fov"], o.at("fov"));
    if (*c.fov >= 180) bad(o.at("fov"), "must be < 180 (degrees), got " + num_str(*c.fov));
  }
  return c;
}

}  // namespace qbond::scene_detail
