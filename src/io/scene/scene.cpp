#include "qbond/io/scene.hpp"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <map>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include "qbond/builders/builders.hpp"
#include "qbond/io/files.hpp"
#include "qbond/builders/gas.hpp"
#include "qbond/laws/materials.hpp"
#include "qbond/model/ordering.hpp"
#include "qbond/builders/packing.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/model/selection.hpp"
#include "heuristics/spatial_hash.hpp"

namespace qbond {
using json = nlohmann::json;

SceneError::SceneError(const std::string& source, std::string p, std::string r)
    : std::runtime_error(source + ": " + (p.empty() ? "" : p + ": ") + r), path(std::move(p)), rule(std::move(r)) {}

namespace {

constexpr double kMaxQuanta = 5e7;  // a scene larger than this is a typo, not a simulation

/// Thrown inside the parser; parse_scene adds the source name.
struct Bad {
  std::string path, rule;
};
[[noreturn]] void bad(const std::string& path, const std::string& rule) { throw Bad{path, rule}; }

std::string num_str(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

std::string type_name(const json& j) {
  if (j.is_number()) return "a number";
  if (j.is_boolean()) return "a boolean";
  if (j.is_string()) return "a string";
  if (j.is_array()) return "an array";
  if (j.is_object()) return "an object";
  return "null";
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

double number(const json& j, const std::string& path) {
  if (!j.is_number()) bad(path, "expected a number, got " + type_name(j));
  const double v = j.get<double>();
  if (!std::isfinite(v)) bad(path, "must be finite");
  return v;
}
double positive(const json& j, const std::string& path) {
  const double v = number(j, path);
  if (!(v > 0)) bad(path, "must be > 0, got " + num_str(v));
  return v;
}
double non_negative(const json& j, const std::string& path) {
  const double v = number(j, path);
  if (v < 0) bad(path, "must be >= 0, got " + num_str(v));
  return v;
}
std::uint64_t integer(const json& j, const std::string& path, std::int64_t min) {
  if (!j.is_number_integer()) bad(path, "expected an integer, got " + (j.is_number() ? "a fractional number" : type_name(j)));
  if (j.is_number_unsigned()) {
    const auto v = j.get<std::uint64_t>();
    if (min > 0 && v < static_cast<std::uint64_t>(min)) bad(path, "must be >= " + std::to_string(min) + ", got " + std::to_string(v));
    return v;
  }
  const auto v = j.get<std::int64_t>();
  if (v < min) bad(path, "must be >= " + std::to_string(min) + ", got " + std::to_string(v));
  return static_cast<std::uint64_t>(v);
}
bool boolean(const json& j, const std::string& path) {
  if (!j.is_boolean()) bad(path, "expected true or false, got " + type_name(j));
  return j.get<bool>();
}
std::string string(const json& j, const std::string& path) {
  if (!j.is_string()) bad(path, "expected a string, got " + type_name(j));
  return j.get<std::string>();
}
Vec3 vec3(const json& j, const std::string& path) {
  if (!j.is_array() || j.size() != 3) bad(path, "expected an array of 3 numbers, got " + (j.is_array() ? "an array of " + std::to_string(j.size()) : type_name(j)));
  return {number(j[0], path + "[0]"), number(j[1], path + "[1]"), number(j[2], path + "[2]")};
}
Vec3 direction(const json& j, const std::string& path) {
  const Vec3 v = vec3(j, path);
  if (!(v.norm() > 0)) bad(path, "must be a non-zero vector");
  return v.normalized();
}
const json& array(const json& j, const std::string& path) {
  if (!j.is_array()) bad(path, "expected an array, got " + type_name(j));
  return j;
}
/// One of a fixed set of names.
template <class T>
T choice(const json& j, const std::string& path, std::initializer_list<std::pair<const char*, T>> names) {
  const std::string s = string(j, path);
  std::vector<std::string> all;
  for (const auto& [n, v] : names) {
    if (s == n) return v;
    all.emplace_back(n);
  }
  bad(path, "unknown value '" + s + "' (accepted: " + join(all) + ")");
}

/// An object whose keys are checked against the accepted ones.
class Obj {
 public:
  Obj(const json& j, std::string path, std::initializer_list<const char*> keys)
      : Obj(j, std::move(path), std::vector<const char*>(keys)) {}
  Obj(const json& j, std::string path, const std::vector<const char*>& keys) : j_(j), path_(std::move(path)) {
    if (!j.is_object()) bad(path_, "expected an object, got " + type_name(j));
    for (const auto& [k, v] : j.items())
      if (std::find_if(keys.begin(), keys.end(), [&](const char* a) { return k == a; }) == keys.end()) {
        std::vector<std::string> all(keys.begin(), keys.end());
        bad(at(k), "unknown key (accepted: " + join(all) + ")");
      }
  }
  bool has(const char* k) const { return j_.contains(k); }
  const json& operator[](const char* k) const { return j_.at(k); }
  const json& required(const char* k) const {
    if (!has(k)) bad(at(k), "required key missing");
    return j_.at(k);
  }
  std::string at(const std::string& k) const { return path_.empty() ? k : path_ + "." + k; }
  const std::string& path() const { return path_; }
  /// Exactly one of two keys; returns whether it is the first.
  bool one_of(const char* a, const char* b) const {
    if (has(a) == has(b))
      bad(path_.empty() ? std::string(a) : path_, has(a) ? std::string("give either '") + a + "' or '" + b + "', not both"
                                                       : std::string("one of '") + a + "' or '" + b + "' is required");
    return has(a);
  }

 private:
  const json& j_;
  std::string path_;
};

std::string item(const std::string& path, std::size_t k) { return path + "[" + std::to_string(k) + "]"; }

std::uint64_t pair_key(Index a, Index b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}

struct Material {
  BondSpec bond;              ///< stiffness 0 when the material is given by a modulus
  double youngs_modulus = 0;  ///< [Pa]; > 0: bond stiffness from the body's lattice (materials.hpp)
  double density = 0;         ///< [kg/m³]; > 0: quanta masses from the body's lattice
};

class Builder {
 public:
  Builder(const json& root, std::string default_name, SceneFiles files = {})
      : root_(root), default_name_(std::move(default_name)), files_(std::move(files)) {}

  // Renumbers the built world for locality (ordering.hpp), and with it every per-quanta list the
  // scene holds; ids in the scene stay the user's (Model::quanta_id).
  static void renumber_for_locality(Scene& s) {
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

  Scene build() {
    Scene s;
    json res = root_;
    Obj top(root_, "",
            {"name", "description", "seed", "timestep", "steps", "duration", "gravity", "integrator", "adaptive", "limits",
             "materials", "bodies", "bonds", "anchors", "loads", "heuristics", "output"});
    s.name = top.has("name") ? string(top["name"], "name") : default_name_;
    s.description = top.has("description") ? string(top["description"], "description") : "";
    s.seed = top.has("seed") ? integer(top["seed"], "seed", 0) : 1;
    s.timestep = positive(top.required("timestep"), "timestep");
    if (top.one_of("steps", "duration")) {
      s.steps = integer(top["steps"], "steps", 0);
    } else {
      const double d = positive(top["duration"], "duration");
      s.steps = static_cast<std::uint64_t>(std::ceil(d / s.timestep - 1e-9));
    }
    World& w = s.world;
    w.model.gravity = top.has("gravity") ? vec3(top["gravity"], "gravity") : Vec3::Zero();
    w.state.rng = Rng{s.seed};
    s.integrator = integrator(top.has("integrator") ? top["integrator"] : json::object());
    s.limits = limits(top.has("limits") ? top["limits"] : json::object());
    if (top.has("adaptive")) s.adaptive = adaptive(top["adaptive"], s.timestep, static_cast<double>(s.steps) * s.timestep);
    if (top.has("materials")) materials(top["materials"], res["materials"]);
    bodies(top.required("bodies"), res["bodies"], w);
    if (top.has("bonds")) bonds(array(top["bonds"], "bonds"), w);
    check_overlaps(w);
    if (top.has("anchors")) anchors(array(top["anchors"], "anchors"), w);
    if (top.has("loads")) loads(array(top["loads"], "loads"), w);
    if (top.has("heuristics")) s.heuristics = heuristics(array(top["heuristics"], "heuristics"), w);
    w.state.obstacle_impulse.assign(obstacles_, ObstacleImpulse{});
    s.output = output(top.has("output") ? top["output"] : json::object(), s.steps, w);
    renumber_for_locality(s);

    res["name"] = s.name;
    res["description"] = s.description;
    res["seed"] = s.seed;
    res["steps"] = s.steps;
    res.erase("duration");
    res["gravity"] = {w.model.gravity.x(), w.model.gravity.y(), w.model.gravity.z()};
    const IntegratorConfig& c = s.integrator;
    res["integrator"] = {{"type", to_string(c.type)},          {"neighbours", to_string(c.neighbours)},
                         {"solver", to_string(c.solver)},      {"iterations", c.iterations},
                         {"max_iterations", c.max_iterations}, {"tolerance", c.tolerance},
                         {"chebyshev_rho", c.chebyshev_rho},   {"warm_start", to_string(c.warm_start)},
                         {"restore_momentum", c.restore_momentum}, {"threads", c.threads},
                         {"newton_iterations", c.newton_iterations}, {"newton_polish", c.newton_polish},
                         {"restore_energy", c.restore_energy}};
    res["limits"] = {{"max_speed", s.limits.max_speed}, {"energy_growth", s.limits.energy_growth}};
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

 private:
  IntegratorConfig integrator(const json& j) {
    Obj o(j, "integrator",
          {"type", "neighbours", "solver", "iterations", "max_iterations", "tolerance", "chebyshev_rho", "warm_start",
           "restore_momentum", "threads", "newton_iterations", "newton_polish", "restore_energy"});
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
    parse("neighbours", parse_neighbour_model, c.neighbours);
    parse("solver", parse_coupled_solver, c.solver);
    parse("warm_start", parse_warm_start, c.warm_start);
    if (o.has("iterations")) c.iterations = static_cast<int>(integer(o["iterations"], o.at("iterations"), 1));
    if (o.has("max_iterations"))
      c.max_iterations = static_cast<int>(integer(o["max_iterations"], o.at("max_iterations"), 0));
    if (o.has("tolerance")) c.tolerance = positive(o["tolerance"], o.at("tolerance"));
    if (o.has("chebyshev_rho")) {
      c.chebyshev_rho = non_negative(o["chebyshev_rho"], o.at("chebyshev_rho"));
      if (c.chebyshev_rho >= 1) bad(o.at("chebyshev_rho"), "must be < 1, got " + num_str(c.chebyshev_rho));
    }
    if (o.has("newton_iterations"))
      c.newton_iterations = static_cast<int>(integer(o["newton_iterations"], o.at("newton_iterations"), 1));
    if (o.has("newton_polish")) c.newton_polish = boolean(o["newton_polish"], o.at("newton_polish"));
    if (o.has("threads")) c.threads = static_cast<int>(integer(o["threads"], o.at("threads"), 0));
    if (o.has("restore_momentum")) c.restore_momentum = boolean(o["restore_momentum"], o.at("restore_momentum"));
    if (o.has("restore_energy")) c.restore_energy = boolean(o["restore_energy"], o.at("restore_energy"));
    return c;
  }

  AdaptiveConfig adaptive(const json& j, double timestep, double horizon) {
    Obj o(j, "adaptive", {"error", "energy", "min_step", "max_step", "safety"});
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

  BlowupLimits limits(const json& j) {
    Obj o(j, "limits", {"max_speed", "energy_growth"});
    BlowupLimits l;
    if (o.has("max_speed")) l.max_speed = positive(o["max_speed"], o.at("max_speed"));
    if (o.has("energy_growth")) l.energy_growth = positive(o["energy_growth"], o.at("energy_growth"));
    return l;
  }

  void materials(const json& j, json& res) {
    if (!j.is_object()) bad("materials", "expected an object (material name -> parameters), got " + type_name(j));
    for (const auto& [name, mj] : j.items()) {
      Obj o(mj, "materials." + name,
            {"law", "stiffness", "youngs_modulus", "density", "damping", "damping_model", "eps"});
      Material m;
      BondSpec& b = m.bond;
      b.law = o.has("law") ? choice<Law>(o["law"], o.at("law"), {{"linear", Law::linear}, {"inverse", Law::inverse}})
                           : Law::linear;
      if (o.has("stiffness") == o.has("youngs_modulus"))
        bad("materials." + name, o.has("stiffness") ? "give either 'stiffness' or 'youngs_modulus', not both"
                                                    : "one of 'stiffness' or 'youngs_modulus' is required");
      if (o.has("stiffness")) b.stiffness = positive(o["stiffness"], o.at("stiffness"));
      if (o.has("youngs_modulus")) {
        if (b.law != Law::linear) bad(o.at("youngs_modulus"), "calibrates linear bonds only (law is " + std::string(to_string(b.law)) + ")");
        m.youngs_modulus = positive(o["youngs_modulus"], o.at("youngs_modulus"));
      }
      if (o.has("density")) m.density = positive(o["density"], o.at("density"));
      b.damping = o.has("damping") ? non_negative(o["damping"], o.at("damping")) : 0.0;
      b.damping_model = o.has("damping_model")
                            ? choice<DampingModel>(o["damping_model"], o.at("damping_model"),
                                                   {{"axial", DampingModel::axial}, {"isotropic", DampingModel::isotropic}})
                            : DampingModel::axial;
      if (o.has("eps")) {
        if (b.law != Law::inverse) bad(o.at("eps"), "only the inverse law has a regularisation length");
        b.eps = positive(o["eps"], o.at("eps"));
      }
      materials_[name] = m;
      json& r = res[name];
      r["law"] = to_string(b.law);
      r["damping"] = b.damping;
      r["damping_model"] = to_string(b.damping_model);
    }
  }

  // A material for a single bond: it must say its stiffness (a modulus needs a lattice).
  BondSpec bond_material(const json& j, const std::string& path) {
    const Material& m = material(j, path);
    if (m.youngs_modulus > 0)
      bad(path, "material '" + j.get<std::string>() +
                    "' is given by youngs_modulus, which calibrates lattices and chains; a single bond needs 'stiffness'");
    return m.bond;
  }

  const Material& material(const json& j, const std::string& path) {
    const std::string name = string(j, path);
    if (auto it = materials_.find(name); it != materials_.end()) return it->second;
    std::vector<std::string> names;
    for (const auto& [k, v] : materials_) names.push_back(k);
    bad(path, "unknown material '" + name + "' (defined: " + (names.empty() ? "none" : join(names)) + ")");
  }

  void bodies(const json& j, json& res, World& w) {
    if (!array(j, "bodies").size()) bad("bodies", "must hold at least one body");
    for (std::size_t k = 0; k < j.size(); ++k) body(j[k], item("bodies", k), res[k], w);
  }

  void body(const json& j, const std::string& path, json& res, World& w) {
    if (!j.is_object()) bad(path, "expected an object, got " + type_name(j));
    const std::string type = j.contains("type") ? string(j["type"], path + ".type") : "";
    static const std::initializer_list<const char*> common = {"name", "type", "origin", "rotation", "velocity",
                                                              "angular_velocity"};
    auto keys = [&](std::initializer_list<const char*> extra) {
      std::vector<const char*> all(common);
      all.insert(all.end(), extra);
      return all;
    };
    std::vector<const char*> accepted;
    if (type == "lattice")
      accepted = keys({"cell", "size", "spacing", "neighbors", "thickness", "material", "quanta_mass", "total_mass"});
    else if (type == "sheet")
      accepted = keys({"size", "spacing", "neighbors", "bending", "thickness", "material", "quanta_mass", "total_mass"});
    else if (type == "chain")
      accepted = keys({"start", "end", "count", "area", "material", "quanta_mass", "total_mass"});
    else if (type == "quanta")
      accepted = keys({"positions", "masses", "mass", "velocities", "volume"});
    else if (type == "packing")
      accepted = keys({"points", "size", "min_distance", "count", "bond_radius", "isolated", "seed", "material",
                       "quanta_mass", "total_mass"});
    else if (type == "mesh")
      accepted = keys({"file", "scale", "spacing", "neighbors", "isolated", "material", "quanta_mass", "total_mass"});
    else if (type == "gas")
      accepted = keys({"size", "count", "min_distance", "quanta_mass", "total_mass", "kT", "speeds", "seed"});
    else if (type.empty())
      bad(path + ".type", "required key missing");
    else
      bad(path + ".type", "unknown body type '" + type + "' (accepted: lattice, sheet, chain, quanta, packing, mesh, gas)");
    for (const auto& [key, v] : j.items())
      if (std::find(accepted.begin(), accepted.end(), key) == accepted.end()) {
        std::vector<std::string> names(accepted.begin(), accepted.end());
        bad(path + "." + key, "unknown key for a " + type + " body (accepted: " + join(names) + ")");
      }
    auto req = [&](const char* key) -> const json& {
      if (!j.contains(key)) bad(path + "." + key, "required key missing");
      return j[key];
    };
    auto at = [&](const char* key) { return path + "." + key; };
    const std::string name = string(req("name"), at("name"));
    if (auto it = body_index_.find(name); it != body_index_.end())
      bad(at("name"), "duplicate body name '" + name + "' (also bodies[" + std::to_string(it->second) + "])");
    const Index id = w.add_body(name);
    body_index_[name] = id;

    // Sizes first, so that a typo does not allocate a billion quanta.
    auto sizes = [&](std::size_t dims) {
      const json& s = req("size");
      if (!s.is_array() || s.size() != dims)
        bad(at("size"), "expected an array of " + std::to_string(dims) + " integers for this cell");
      std::array<int, 3> n{1, 1, 1};
      double total = 1;
      for (std::size_t d = 0; d < dims; ++d) {
        const auto v = integer(s[d], item(at("size"), d), 1);
        if (static_cast<double>(v) > kMaxQuanta) bad(item(at("size"), d), "is too large");
        n[d] = static_cast<int>(v);
        total *= static_cast<double>(v);
      }
      return std::pair{n, total};
    };
    // A material given by a modulus or a density fixes the bonds' stiffness or the quanta's
    // mass from the body's geometry (materials.hpp); the resolved scene records the numbers.
    const Material* mat = nullptr;
    if (type != "quanta" && type != "gas") mat = &material(req("material"), at("material"));
    auto mass_of = [&](double count, double calibrated) {
      const bool per = j.contains("quanta_mass");
      if (calibrated > 0) {
        if (per || j.contains("total_mass"))
          bad(path, "the mass comes from the density of material '" + j["material"].get<std::string>() +
                        "'; drop 'quanta_mass'/'total_mass'");
        res["quanta_mass"] = calibrated;
        return calibrated;
      }
      if (per == j.contains("total_mass"))
        bad(path, per ? "give either 'quanta_mass' or 'total_mass', not both"
                      : "one of 'quanta_mass' or 'total_mass' is required");
      return per ? positive(j["quanta_mass"], at("quanta_mass")) : positive(j["total_mass"], at("total_mass")) / count;
    };
    auto lattice_bond = [&](const LatticeCell& cell, double a, double thickness) {
      BondSpec bond = mat->bond;
      if (mat->youngs_modulus > 0) {
        bond.stiffness = calibrated_stiffness(cell, mat->youngs_modulus, a, thickness);
        res["stiffness"] = bond.stiffness;
      }
      return bond;
    };
    auto lattice_mass = [&](const LatticeCell& cell, double a, double thickness) {
      return mat->density > 0 ? calibrated_mass(cell, mat->density, a, thickness) : 0.0;
    };
    auto too_many = [&](double count) {
      if (count > kMaxQuanta)
        bad(at("size"), "would make " + num_str(count) + " quanta (limit " + num_str(kMaxQuanta) + ")");
    };
    // A square cell is a sheet of some thickness (default: the spacing), which turns its
    // stiffness per length into a modulus and its area per quanta into a volume.
    auto thickness = [&](double a, bool square) {
      if (!j.contains("thickness")) return a;
      if (!square) bad(at("thickness"), "only square (2D) cells have a thickness");
      return positive(j["thickness"], at("thickness"));
    };
    std::vector<Index> ids;
    if (type == "lattice" || type == "sheet") {
      const std::string cell = type == "sheet" ? "square"
                                               : choice<std::string>(req("cell"), at("cell"),
                                                                     {{"square", "square"}, {"cubic", "cubic"}, {"fcc", "fcc"}});
      const double a = positive(req("spacing"), at("spacing"));
      const double t = thickness(a, cell == "square");
      if (cell == "square") {
        const auto [n, count] = sizes(2);
        too_many(count);
        SquareLattice l;
        l.size = {n[0], n[1]};
        l.spacing = a;
        l.thickness = t;
        if (j.contains("neighbors"))
          l.diagonals = choice<bool>(j["neighbors"], at("neighbors"), {{"nearest", false}, {"diagonal", true}});
        if (j.contains("bending")) l.bending = boolean(j["bending"], at("bending"));
        const LatticeCell c = square_cell(l.diagonals, l.bending);
        l.bond = lattice_bond(c, a, t);
        l.quanta_mass = mass_of(count, lattice_mass(c, a, t));
        res["neighbors"] = l.diagonals ? "diagonal" : "nearest";
        if (type == "sheet") res["bending"] = l.bending;
        res["thickness"] = t;
        ids = add_square_lattice(w, l, id);
      } else if (cell == "cubic") {
        const auto [n, count] = sizes(3);
        too_many(count);
        CubicLattice l;
        l.size = n;
        l.spacing = a;
        if (j.contains("neighbors"))
          l.shells = choice<Shells>(j["neighbors"], at("neighbors"),
                                    {{"nearest", Shells::nearest},
                                     {"face_diagonal", Shells::face_diagonal},
                                     {"body_diagonal", Shells::body_diagonal}});
        const LatticeCell c = cubic_cell(l.shells);
        l.bond = lattice_bond(c, a, t);
        l.quanta_mass = mass_of(count, lattice_mass(c, a, t));
        res["neighbors"] = l.shells == Shells::nearest         ? "nearest"
                           : l.shells == Shells::face_diagonal ? "face_diagonal"
                                                               : "body_diagonal";
        ids = add_cubic_lattice(w, l, id);
      } else {
        const auto [n, cells] = sizes(3);
        const double count = std::ceil((2.0 * n[0] + 1) * (2.0 * n[1] + 1) * (2.0 * n[2] + 1) / 2);
        too_many(count);
        FccLattice l;
        l.cells = n;
        l.spacing = a;
        if (j.contains("neighbors"))
          l.second_shell = choice<bool>(j["neighbors"], at("neighbors"), {{"nearest", false}, {"second", true}});
        const LatticeCell c = fcc_cell(l.second_shell);
        l.bond = lattice_bond(c, a, t);
        l.quanta_mass = mass_of(count, lattice_mass(c, a, t));
        res["neighbors"] = l.second_shell ? "second" : "nearest";
        // total_mass must divide by the real site count: rebuild the mass once it is known.
        ids = add_fcc_lattice(w, l, id);
        if (j.contains("total_mass"))
          for (Index i : ids) {
            w.model.mass[i] = j["total_mass"].get<double>() / static_cast<double>(ids.size());
            w.model.inv_mass[i] = 1 / w.model.mass[i];
          }
      }
    } else if (type == "chain") {
      Chain c;
      c.start = vec3(req("start"), at("start"));
      c.end = vec3(req("end"), at("end"));
      if (!((c.end - c.start).norm() > 0)) bad(at("end"), "must differ from start");
      const auto count = integer(req("count"), at("count"), 2);
      too_many(static_cast<double>(count));
      c.count = static_cast<int>(count);
      const double segment = (c.end - c.start).norm() / static_cast<double>(count - 1);
      c.bond = mat->bond;
      const bool calibrated = mat->youngs_modulus > 0 || mat->density > 0;
      if (j.contains("area"))
        c.area = positive(j["area"], at("area"));
      else if (calibrated)
        bad(at("area"), "required: material '" + j["material"].get<std::string>() +
                            "' is given by a modulus or density, which a chain turns into k = E A / segment, m = ρ A segment");
      if (mat->youngs_modulus > 0) {
        c.bond.stiffness = mat->youngs_modulus * c.area / segment;
        res["stiffness"] = c.bond.stiffness;
      }
      c.quanta_mass = mass_of(static_cast<double>(count), mat->density > 0 ? mat->density * c.area * segment : 0.0);
      ids = add_chain(w, c, id);
    } else if (type == "packing") {
      ids = packing_body(j, path, res, w, id, mass_of, *mat);
    } else if (type == "mesh") {
      ids = mesh_body(j, path, res, w, id, mass_of, *mat);
    } else if (type == "gas") {
      ids = gas_body(j, path, res, w, id, mass_of);
    } else {
      const json& pos = array(req("positions"), at("positions"));
      if (pos.empty()) bad(at("positions"), "must hold at least one position");
      too_many(static_cast<double>(pos.size()));
      const bool per = j.contains("masses");
      if (per == j.contains("mass"))
        bad(path, per ? "give either 'masses' or 'mass', not both" : "one of 'masses' or 'mass' is required");
      if (per && (!j["masses"].is_array() || j["masses"].size() != pos.size()))
        bad(at("masses"), "expected an array of " + std::to_string(pos.size()) + " masses (one per position)");
      const double mass = per ? 0.0 : positive(j["mass"], at("mass"));
      const double volume = j.contains("volume") ? positive(j["volume"], at("volume")) : 0.0;
      for (std::size_t k = 0; k < pos.size(); ++k)
        ids.push_back(w.add_quanta(vec3(pos[k], item(at("positions"), k)), Vec3::Zero(),
                                   per ? positive(j["masses"][k], item(at("masses"), k)) : mass, id, volume));
    }
    // Placement: rotate, translate, then the rigid velocity field.
    Placement p;
    if (j.contains("origin")) p.origin = vec3(j["origin"], at("origin"));
    if (j.contains("rotation")) {
      Obj r(j["rotation"], at("rotation"), {"axis", "angle"});
      p.axis = direction(r.required("axis"), r.at("axis"));
      p.angle = number(r.required("angle"), r.at("angle"));
    }
    if (j.contains("velocity")) p.velocity = vec3(j["velocity"], at("velocity"));
    if (j.contains("angular_velocity")) p.angular_velocity = vec3(j["angular_velocity"], at("angular_velocity"));
    // A gas keeps its thermal velocities: the placement's rigid field adds a drift to them.
    std::vector<Vec3> thermal;
    if (type == "gas")
      for (Index i : ids) thermal.push_back(w.state.v[i]);
    place_body(w, ids, p);
    for (std::size_t k = 0; k < thermal.size(); ++k) w.state.v[ids[k]] += thermal[k];
    if (type == "quanta" && j.contains("velocities")) {
      const json& vs = j["velocities"];
      if (!vs.is_array() || vs.size() != ids.size())
        bad(at("velocities"), "expected an array of " + std::to_string(ids.size()) + " velocities (one per position)");
      for (std::size_t k = 0; k < ids.size(); ++k) w.state.v[ids[k]] += vec3(vs[k], item(at("velocities"), k));
    }
    res["origin"] = {p.origin.x(), p.origin.y(), p.origin.z()};
    res["velocity"] = {p.velocity.x(), p.velocity.y(), p.velocity.z()};
    res["angular_velocity"] = {p.angular_velocity.x(), p.angular_velocity.y(), p.angular_velocity.z()};
  }

  /// What a packing or mesh body does with quanta left without a bond.
  Isolated isolated(const json& j, const std::string& path, json& res) {
    const Isolated v = j.contains("isolated") ? choice<Isolated>(j["isolated"], path + ".isolated",
                                                                 {{"drop", Isolated::drop},
                                                                  {"keep", Isolated::keep},
                                                                  {"error", Isolated::error}})
                                              : Isolated::drop;
    res["isolated"] = v == Isolated::drop ? "drop" : v == Isolated::keep ? "keep" : "error";
    return v;
  }

  /// Builders that learn their quanta count only once built (packings, meshes) make 1 kg quanta;
  /// this gives them their mass, `mass_of(count, ρ V)` (whose key checks ran before building),
  /// and the volume each quanta stands for.
  template <class MassOf>
  void set_masses(World& w, const std::vector<Index>& ids, const MassOf& mass_of, const Material& mat, double volume) {
    const double m = mass_of(static_cast<double>(ids.size()), mat.density * volume);
    for (Index i : ids) {
      w.model.mass[i] = m;
      w.model.inv_mass[i] = 1 / m;
      w.model.volume[i] = volume;
    }
  }

  /// A `gas` body: unbonded quanta at random positions with thermal velocities (gas.hpp).
  template <class MassOf>
  std::vector<Index> gas_body(const json& j, const std::string& path, json& res, World& w, Index id,
                              const MassOf& mass_of) {
    auto at = [&](const char* key) { return path + "." + key; };
    auto req = [&](const char* key) -> const json& {
      if (!j.contains(key)) bad(at(key), "required key missing");
      return j[key];
    };
    Gas g;
    g.size = vec3(req("size"), at("size"));
    if (!(g.size.minCoeff() > 0)) bad(at("size"), "every edge must be > 0");
    const auto n = integer(req("count"), at("count"), 2);
    if (static_cast<double>(n) > kMaxQuanta)
      bad(at("count"), "would make " + std::to_string(n) + " quanta (limit " + num_str(kMaxQuanta) + ")");
    g.count = static_cast<std::size_t>(n);
    if (j.contains("min_distance")) g.min_distance = non_negative(j["min_distance"], at("min_distance"));
    g.quanta_mass = mass_of(static_cast<double>(n), 0.0);
    g.kT = positive(req("kT"), at("kT"));
    if (j.contains("speeds"))
      g.speeds = choice<Gas::Speeds>(j["speeds"], at("speeds"),
                                     {{"maxwell", Gas::Speeds::maxwell}, {"equal", Gas::Speeds::equal}});
    g.seed = j.contains("seed") ? integer(j["seed"], at("seed"), 0)
                                : (root_.contains("seed") ? root_["seed"].get<std::uint64_t>() : 1);
    res["quanta_mass"] = g.quanta_mass;
    res["min_distance"] = g.min_distance;
    res["speeds"] = g.speeds == Gas::Speeds::maxwell ? "maxwell" : "equal";
    res["seed"] = g.seed;
    try {
      return add_gas(w, g, id);
    } catch (const std::invalid_argument& e) {
      bad(path, e.what());
    }
  }

  /// A `packing` body: Poisson-disk or random points bonded within a radius (packing.hpp).
  template <class MassOf>
  std::vector<Index> packing_body(const json& j, const std::string& path, json& res, World& w, Index id,
                                  const MassOf& mass_of, const Material& mat) {
    auto at = [&](const char* key) { return path + "." + key; };
    auto req = [&](const char* key) -> const json& {
      if (!j.contains(key)) bad(at(key), "required key missing");
      return j[key];
    };
    PointPacking p;
    p.kind = choice<PointPacking::Kind>(req("points"), at("points"),
                                        {{"poisson", PointPacking::poisson}, {"random", PointPacking::random}});
    const bool poisson = p.kind == PointPacking::poisson;
    p.size = vec3(req("size"), at("size"));
    if (!(p.size.x() > 0 && p.size.y() > 0)) bad(at("size"), "x and y must be > 0");
    if (p.size.z() < 0) bad(at("size"), "z must be >= 0 (0: a flat, 2D packing)");
    if (poisson)
      p.min_distance = positive(req("min_distance"), at("min_distance"));
    else
      p.min_distance = j.contains("min_distance") ? non_negative(j["min_distance"], at("min_distance")) : 0.0;
    if (!poisson || j.contains("count")) {
      const auto n = integer(req("count"), at("count"), poisson ? 0 : 1);
      if (static_cast<double>(n) > kMaxQuanta)
        bad(at("count"), "would make " + std::to_string(n) + " quanta (limit " + num_str(kMaxQuanta) + ")");
      p.count = static_cast<std::size_t>(n);
    }
    if (poisson && max_points(p) > kMaxQuanta)
      bad(at("min_distance"), "would make up to " + num_str(std::round(max_points(p))) + " quanta (limit " +
                                  num_str(kMaxQuanta) + ")");
    p.bond_radius = positive(req("bond_radius"), at("bond_radius"));
    if (poisson && !(p.bond_radius > p.min_distance))
      bad(at("bond_radius"), "must be > min_distance (" + num_str(p.min_distance) +
                                 " m), or no two points are close enough to bond");
    p.seed = j.contains("seed") ? integer(j["seed"], at("seed"), 0)
                                : (root_.contains("seed") ? root_["seed"].get<std::uint64_t>() : 1);
    p.isolated = isolated(j, path, res);
    if (mat.youngs_modulus > 0)
      bad(at("material"), "a modulus calibrates lattices and chains, which have an elasticity theory; give a "
                          "packing's material a 'stiffness'");
    p.bond = mat.bond;
    mass_of(1.0, mat.density);  // the mass keys' errors before the sampling's
    p.quanta_mass = 1;
    std::vector<Index> ids;
    try {
      ids = add_point_packing(w, p, id);
    } catch (const std::invalid_argument& e) {
      bad(path, e.what());
    }
    if (ids.empty())
      bad(at("bond_radius"), "no two points lie within " + num_str(p.bond_radius) + " m: every point is isolated");
    // Each point stands for the box's volume over the points (a flat packing: a layer one mean
    // spacing thick).
    const double per = p.size.x() * p.size.y() / static_cast<double>(ids.size());
    set_masses(w, ids, mass_of, mat, p.size.z() > 0 ? per * p.size.z() : per * std::sqrt(per));
    res["points"] = poisson ? "poisson" : "random";
    res["size"] = {p.size.x(), p.size.y(), p.size.z()};
    res["min_distance"] = p.min_distance;
    res["count"] = p.count;
    res["seed"] = p.seed;
    return ids;
  }

  /// The bytes of a file the scene names, and how the resolved scene names it: an absolute path,
  /// or "builtin:REL" for a file compiled in from scenes/ (which a resumed run finds again).
  std::pair<std::string, std::string> scene_file(const std::string& file, const std::string& path) {
    constexpr std::string_view kBuiltin = "builtin:";
    const bool named_builtin = file.starts_with(kBuiltin);
    if (named_builtin || (files_.builtin && std::filesystem::path(file).is_relative())) {
      const std::string rel = named_builtin ? file.substr(kBuiltin.size()) : file;
      std::vector<std::string> all;
      for (const BuiltinFile& f : builtin_files()) {
        if (f.path == rel) return {std::string(f.data), "builtin:" + rel};
        all.emplace_back(f.path);
      }
      bad(path, "no built-in file '" + rel + "' (built-in files, from scenes/: " + (all.empty() ? "none" : join(all)) +
                    ")");
    }
    std::filesystem::path p(file);
    if (p.is_relative() && !files_.dir.empty()) p = files_.dir / p;
    const std::string where = std::filesystem::absolute(p).lexically_normal().string();
    std::error_code ec;
    if (!std::filesystem::exists(p, ec)) bad(path, "cannot read '" + file + "': no such file (looked for " + where + ")");
    if (!std::filesystem::is_regular_file(p, ec)) bad(path, "cannot read '" + file + "': not a regular file (" + where + ")");
    try {
      return {read_file(p), where};
    } catch (const std::exception& e) {
      bad(path, "cannot read '" + file + "': " + e.what());
    }
  }

  /// A `mesh` body: a closed OBJ/STL mesh voxelised into a simple-cubic lattice (packing.hpp).
  template <class MassOf>
  std::vector<Index> mesh_body(const json& j, const std::string& path, json& res, World& w, Index id,
                               const MassOf& mass_of, const Material& mat) {
    auto at = [&](const char* key) { return path + "." + key; };
    auto req = [&](const char* key) -> const json& {
      if (!j.contains(key)) bad(at(key), "required key missing");
      return j[key];
    };
    const std::string file = string(req("file"), at("file"));
    std::string ext = std::filesystem::path(file).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext != ".obj" && ext != ".stl")
      bad(at("file"), "unknown mesh format '" + ext + "' (accepted: .obj, .stl)");
    MeshLattice m;
    m.spacing = positive(req("spacing"), at("spacing"));
    if (j.contains("scale")) m.scale = positive(j["scale"], at("scale"));
    if (j.contains("neighbors"))
      m.shells = choice<Shells>(j["neighbors"], at("neighbors"),
                                {{"nearest", Shells::nearest},
                                 {"face_diagonal", Shells::face_diagonal},
                                 {"body_diagonal", Shells::body_diagonal}});
    m.isolated = isolated(j, path, res);
    m.bond = mat.bond;
    if (mat.youngs_modulus > 0) {
      m.bond.stiffness = calibrated_stiffness(cubic_cell(m.shells), mat.youngs_modulus, m.spacing);
      res["stiffness"] = m.bond.stiffness;
    }
    mass_of(1.0, mat.density);  // the mass keys' errors before the file's
    const auto [bytes, resolved] = scene_file(file, at("file"));
    try {
      m.mesh = parse_mesh(bytes, file);
      check_closed(m.mesh, file);
    } catch (const std::runtime_error& e) {
      bad(at("file"), e.what());
    }
    const MeshGrid g = mesh_grid(m);
    const double sites = static_cast<double>(g.cells[0]) * static_cast<double>(g.cells[1]) * static_cast<double>(g.cells[2]);
    if (sites > kMaxQuanta)
      bad(at("spacing"), "the mesh's bounding box would hold " + num_str(sites) + " lattice sites (limit " +
                             num_str(kMaxQuanta) + ")");
    m.quanta_mass = 1;
    std::vector<Index> ids;
    try {
      ids = add_mesh_lattice(w, m, id);
    } catch (const std::invalid_argument& e) {
      bad(path, e.what());
    }
    set_masses(w, ids, mass_of, mat, m.spacing * m.spacing * m.spacing);
    res["file"] = resolved;
    res["scale"] = m.scale;
    res["neighbors"] = m.shells == Shells::nearest         ? "nearest"
                       : m.shells == Shells::face_diagonal ? "face_diagonal"
                                                           : "body_diagonal";
    return ids;
  }

  std::vector<Index> selection(const json& j, const std::string& path, const World& w) {
    Obj o(j, path, {"ids", "body", "box", "sphere", "half_space", "all"});
    Selection s;
    if (o.has("body")) {
      const std::string name = string(o["body"], o.at("body"));
      auto it = body_index_.find(name);
      if (it == body_index_.end()) {
        std::vector<std::string> names;
        for (const auto& [k, v] : body_index_) names.push_back(k);
        bad(o.at("body"), "unknown body '" + name + "' (defined: " + join(names) + ")");
      }
      s.body = it->second;
    }
    if (o.has("ids")) {
      std::vector<Index> ids;
      const json& a = array(o["ids"], o.at("ids"));
      for (std::size_t k = 0; k < a.size(); ++k) {
        const auto v = integer(a[k], item(o.at("ids"), k), 0);
        ids.push_back(static_cast<Index>(std::min<std::uint64_t>(v, ~Index{0})));
      }
      s.ids = ids;
    }
    if (o.has("box")) {
      const json& b = o["box"];
      if (!b.is_array() || b.size() != 2) bad(o.at("box"), "expected [[xmin, ymin, zmin], [xmax, ymax, zmax]]");
      s.box = {vec3(b[0], o.at("box") + "[0]"), vec3(b[1], o.at("box") + "[1]")};
      if ((s.box->first.array() > s.box->second.array()).any()) bad(o.at("box"), "min must be <= max in every axis");
    }
    if (o.has("sphere")) {
      Obj sp(o["sphere"], o.at("sphere"), {"center", "radius"});
      s.sphere = {vec3(sp.required("center"), sp.at("center")), positive(sp.required("radius"), sp.at("radius"))};
    }
    if (o.has("half_space")) {
      Obj h(o["half_space"], o.at("half_space"), {"point", "normal"});
      s.half_space = {vec3(h.required("point"), h.at("point")), direction(h.required("normal"), h.at("normal"))};
    }
    if (o.has("all")) {
      if (!boolean(o["all"], o.at("all"))) bad(o.at("all"), "must be true when given");
      s.all = true;
    }
    if (j.empty()) bad(path, "needs at least one criterion (ids, body, box, sphere, half_space, all)");
    std::vector<Index> q;
    try {
      q = select(w, s);
    } catch (const std::out_of_range& e) {
      bad(o.at("ids"), std::string(e.what()) + (s.body ? " of the body" : ""));
    }
    if (q.empty()) bad(path, "selects no quanta");
    return q;
  }

  void bonds(const json& j, World& w) {
    std::unordered_set<std::uint64_t> existing;
    for (std::size_t b = 0; b < w.num_bonds(); ++b) existing.insert(pair_key(w.model.bond_i[b], w.model.bond_j[b]));
    for (std::size_t k = 0; k < j.size(); ++k) {
      const std::string path = item("bonds", k);
      if (!j[k].is_object()) bad(path, "expected an object, got " + type_name(j[k]));
      if (j[k].contains("between")) {
        Obj o(j[k], path, {"between", "body", "material", "rest_length"});
        const json& ends = o["between"];
        if (!ends.is_array() || ends.size() != 2) bad(o.at("between"), "expected two quanta ids [i, j]");
        json ids = json::object();
        ids["ids"] = ends;
        if (o.has("body")) ids["body"] = o["body"];
        // Reuse the selection rules (ranges, body-local ids) on the pair, keeping its order.
        const std::vector<Index> q = selection(ids, path, w);
        if (q.size() != 2) bad(o.at("between"), "a bond needs two different quanta");
        Index a = q[0], b = q[1];
        if (ends[0].get<std::uint64_t>() > ends[1].get<std::uint64_t>()) std::swap(a, b);
        BondSpec spec = bond_material(o.required("material"), o.at("material"));
        if (o.has("rest_length")) spec.rest_length = non_negative(o["rest_length"], o.at("rest_length"));
        if (!existing.insert(pair_key(a, b)).second)
          bad(o.at("between"), "quanta " + std::to_string(a) + " and " + std::to_string(b) + " are already bonded");
        w.add_bond(a, b, spec);
      } else {
        Obj o(j[k], path, {"from", "to", "within", "material", "rest_length"});
        const std::vector<Index> from = selection(o.required("from"), o.at("from"), w);
        const std::vector<Index> to = selection(o.required("to"), o.at("to"), w);
        const double r = positive(o.required("within"), o.at("within"));
        BondSpec spec = bond_material(o.required("material"), o.at("material"));
        if (o.has("rest_length")) spec.rest_length = non_negative(o["rest_length"], o.at("rest_length"));
        std::size_t made = 0;
        pairs_within(w.state.x, from, to, r, [&](Index a, Index b) {
          if (!existing.insert(pair_key(a, b)).second) return;
          w.add_bond(a, b, spec);
          ++made;
        });
        if (made == 0) bad(o.at("within"), "no unbonded pair of quanta lies within " + num_str(r) + " m");
      }
    }
  }

  void check_overlaps(const World& w) {
    double shortest = INFINITY;
    for (std::size_t b = 0; b < w.num_bonds(); ++b)
      if (w.state.rest[b] > 0) shortest = std::min(shortest, w.state.rest[b]);
    const double limit = std::isfinite(shortest) ? 0.01 * shortest : 1e-9;
    for (const auto& [a, b] : pairs_within_radius(w.state.x, limit)) {
      const auto& names = w.model.body_names;
      bad("bodies", "quanta " + std::to_string(a) + " (body '" + names[w.model.body[a]] + "') and quanta " +
                        std::to_string(b) + " (body '" + names[w.model.body[b]] + "') overlap: " +
                        num_str((w.state.x[a] - w.state.x[b]).norm()) + " m apart (limit " + num_str(limit) +
                        " m, 1% of the shortest bond)");
    }
  }

  void anchors(const json& j, World& w) {
    std::unordered_map<Index, std::size_t> by;
    for (std::size_t k = 0; k < j.size(); ++k) {
      Obj o(j[k], item("anchors", k), {"select", "motion"});
      const std::vector<Index> q = selection(o.required("select"), o.at("select"), w);
      for (Index i : q)
        if (auto [it, fresh] = by.emplace(i, k); !fresh)
          bad(o.at("select"), "quanta " + std::to_string(i) + " is already anchored by anchors[" +
                                  std::to_string(it->second) + "]");
      Motion m;
      if (o.has("motion")) {
        const json& mj = o["motion"];
        const std::string path = o.at("motion");
        if (!mj.is_object() || mj.size() != 1)
          bad(path, "expected one of {\"fixed\": {}}, {\"translate\": {...}}, {\"rotate\": {...}}");
        const std::string kind = mj.begin().key();
        const std::string at = path + "." + kind;
        if (kind == "fixed") {
          Obj(mj[kind], at, {});
        } else if (kind == "translate") {
          Obj t(mj[kind], at, {"velocity"});
          m.type = MotionType::translate;
          m.velocity = vec3(t.required("velocity"), t.at("velocity"));
        } else if (kind == "rotate") {
          Obj r(mj[kind], at, {"axis", "center", "rate"});
          m.type = MotionType::rotate;
          m.axis = direction(r.required("axis"), r.at("axis"));
          m.center = vec3(r.required("center"), r.at("center"));
          m.rate = number(r.required("rate"), r.at("rate"));
        } else {
          bad(at, "unknown motion (accepted: fixed, translate, rotate)");
        }
      }
      w.prescribe(q, m);
    }
  }

  void loads(const json& j, World& w) {
    for (std::size_t k = 0; k < j.size(); ++k) {
      Obj o(j[k], item("loads", k), {"select", "force"});
      const std::vector<Index> q = selection(o.required("select"), o.at("select"), w);
      const Vec3 f = vec3(o.required("force"), o.at("force"));
      for (Index i : q)
        if (w.model.is_kinematic(i))
          bad(o.at("select"), "selects anchored quanta " + std::to_string(i) + ": a load on it would do nothing");
      w.add_load(q, f);
    }
  }

  // Per bond: 1 when both ends are in the entry's `select` (every bond without one).
  // A rule's `select`: per quanta, 1 when selected (empty: all).
  std::vector<std::uint8_t> quanta_mask(const Obj& o, const World& w) {
    if (!o.has("select")) return {};
    std::vector<std::uint8_t> in(w.num_quanta(), 0);
    for (Index i : selection(o["select"], o.at("select"), w)) in[i] = 1;
    return in;
  }

  ContactMaterial contact_material(const Obj& o) {
    ContactMaterial c;
    if (o.has("restitution")) {
      c.restitution = non_negative(o["restitution"], o.at("restitution"));
      if (c.restitution > 1) bad(o.at("restitution"), "must be <= 1, got " + num_str(c.restitution));
    }
    if (o.has("friction")) c.friction = non_negative(o["friction"], o.at("friction"));
    return c;
  }

  std::vector<HeuristicSpec> heuristics(const json& j, const World& w) {
    std::vector<HeuristicSpec> out;
    for (std::size_t k = 0; k < j.size(); ++k) {
      const std::string path = item("heuristics", k);
      if (!j[k].is_object() || !j[k].contains("type"))
        bad(path, "expected an object with a \"type\" (break, plastic, ground, plane, sphere, box, contact, form, liquid)");
      const std::string type = string(j[k]["type"], path + ".type");
      if (type == "break") {
        static const std::initializer_list<const char*> limits = {"max_strain", "max_compression", "max_tension",
                                                                  "max_stress", "max_von_mises"};
        std::vector<const char*> keys(limits);
        keys.insert(keys.end(), {"type", "probability", "select"});
        Obj o(j[k], path, keys);
        BreakRule r;
        double* fields[] = {&r.max_strain, &r.max_compression, &r.max_tension, &r.max_stress, &r.max_von_mises};
        bool any = false;
        for (std::size_t f = 0; f < limits.size(); ++f) {
          const char* key = limits.begin()[f];
          if (!o.has(key)) continue;
          *fields[f] = positive(o[key], o.at(key));
          any = true;
        }
        if (!any) bad(path, "give at least one of " + join(std::vector<std::string>(limits.begin(), limits.end())));
        if ((o.has("max_stress") || o.has("max_von_mises")) &&
            std::none_of(w.model.volume.begin(), w.model.volume.end(), [](double v) { return v > 0; }))
          bad(path, "stress limits need quanta with volumes (lattice, sheet and chain bodies have them; "
                    "give 'quanta' bodies a 'volume')");
        if (o.has("probability")) {
          r.probability = positive(o["probability"], o.at("probability"));
          if (r.probability > 1) bad(o.at("probability"), "must be <= 1, got " + num_str(r.probability));
        }
        r.quanta = quanta_mask(o, w);
        out.emplace_back(std::move(r));
      } else if (type == "plastic") {
        Obj o(j[k], path, {"type", "yield_strain", "hardening", "max_plastic_strain", "select"});
        PlasticRule r;
        r.yield_strain = positive(o.required("yield_strain"), o.at("yield_strain"));
        if (o.has("hardening")) {
          r.hardening = non_negative(o["hardening"], o.at("hardening"));
          if (r.hardening >= 1) bad(o.at("hardening"), "must be < 1, got " + num_str(r.hardening));
        }
        if (o.has("max_plastic_strain")) r.max_plastic_strain = positive(o["max_plastic_strain"], o.at("max_plastic_strain"));
        r.quanta = quanta_mask(o, w);
        out.emplace_back(std::move(r));
      } else if (type == "ground" || type == "plane" || type == "sphere" || type == "box") {
        static const std::initializer_list<const char*> common = {"type", "restitution", "friction", "margin"};
        std::vector<const char*> keys(common);
        if (type == "ground") keys.push_back("height");
        if (type == "plane") keys.insert(keys.end(), {"point", "normal"});
        if (type == "sphere") keys.insert(keys.end(), {"center", "radius"});
        if (type == "box") keys.insert(keys.end(), {"center", "size", "rotation"});
        if (type == "sphere" || type == "box") keys.push_back("inside");
        Obj o(j[k], path, keys);
        Obstacle ob;
        ob.material = contact_material(o);
        if (o.has("margin")) ob.margin = non_negative(o["margin"], o.at("margin"));
        if (type == "ground") {
          ob.center = Vec3(0, 0, o.has("height") ? number(o["height"], o.at("height")) : 0.0);
        } else if (type == "plane") {
          ob.center = vec3(o.required("point"), o.at("point"));
          ob.normal = direction(o.required("normal"), o.at("normal"));
        } else if (type == "sphere") {
          ob.shape = Obstacle::Shape::sphere;
          ob.center = vec3(o.required("center"), o.at("center"));
          ob.radius = positive(o.required("radius"), o.at("radius"));
        } else {
          ob.shape = Obstacle::Shape::box;
          ob.center = vec3(o.required("center"), o.at("center"));
          const Vec3 size = vec3(o.required("size"), o.at("size"));
          if (!(size.minCoeff() > 0)) bad(o.at("size"), "every edge must be > 0");
          ob.half_extents = 0.5 * size;
          if (o.has("rotation")) {
            Obj r(o["rotation"], o.at("rotation"), {"axis", "angle"});
            ob.rotation = Eigen::AngleAxisd(number(r.required("angle"), r.at("angle")),
                                            direction(r.required("axis"), r.at("axis")))
                              .toRotationMatrix();
          }
        }
        if (o.has("inside")) {
          ob.inside = boolean(o["inside"], o.at("inside"));
          const double room = ob.shape == Obstacle::Shape::sphere ? ob.radius : ob.half_extents.minCoeff();
          if (ob.inside && !(ob.margin < room))
            bad(o.at("margin"), "must be below the container's " + std::string(ob.shape == Obstacle::Shape::sphere ? "radius" : "half size") +
                                    " " + num_str(room) + " m, or no quanta fits inside");
        }
        // Every obstacle records the impulse it gives (diagnostics' obstacle<k>_ columns).
        ob.record = static_cast<std::int32_t>(obstacles_++);
        out.emplace_back(ob);
      } else if (type == "contact") {
        Obj o(j[k], path, {"type", "radius", "restitution", "friction", "iterations", "same_body"});
        QuantaContactRule r;
        r.radius = positive(o.required("radius"), o.at("radius"));
        r.material = contact_material(o);
        if (o.has("iterations")) r.iterations = static_cast<int>(integer(o["iterations"], o.at("iterations"), 1));
        if (o.has("same_body")) r.same_body = boolean(o["same_body"], o.at("same_body"));
        check_contact_radius(r, o, w);
        out.emplace_back(r);
      } else if (type == "form") {
        Obj o(j[k], path, {"type", "capture_radius", "pairs", "max_bonds", "min_age", "rest_length", "material", "select"});
        FormRule r;
        r.capture_radius = positive(o.required("capture_radius"), o.at("capture_radius"));
        if (o.has("pairs"))
          r.pairs = choice<FormPairs>(o["pairs"], o.at("pairs"),
                                      {{"any", FormPairs::any},
                                       {"same_body", FormPairs::same_body},
                                       {"other_body", FormPairs::other_body}});
        if (o.has("max_bonds")) r.max_bonds = static_cast<int>(integer(o["max_bonds"], o.at("max_bonds"), 1));
        if (o.has("min_age")) r.min_age = non_negative(o["min_age"], o.at("min_age"));
        if (o.has("rest_length")) r.rest_length = positive(o["rest_length"], o.at("rest_length"));
        r.bond = bond_material(o.required("material"), o.at("material"));
        r.quanta = quanta_mask(o, w);
        out.emplace_back(std::move(r));
      } else if (type == "liquid") {
        // A preset: bonds break past max_strain and form again within the capture radius, at the
        // rest length `spacing` the liquid keeps between its quanta (its density).
        Obj o(j[k], path, {"type", "spacing", "max_strain", "capture_radius", "max_bonds", "material", "select"});
        const double a = positive(o.required("spacing"), o.at("spacing"));
        BreakRule br;
        br.max_strain = o.has("max_strain") ? positive(o["max_strain"], o.at("max_strain")) : 0.3;
        FormRule fr;
        fr.capture_radius = o.has("capture_radius") ? positive(o["capture_radius"], o.at("capture_radius")) : 1.2 * a;
        if (fr.capture_radius >= a * (1 + br.max_strain))
          bad(o.at("capture_radius"), "must be below spacing x (1 + max_strain) = " + num_str(a * (1 + br.max_strain)) +
                                          " m, or new bonds would break at once");
        fr.max_bonds = o.has("max_bonds") ? static_cast<int>(integer(o["max_bonds"], o.at("max_bonds"), 1)) : 12;
        fr.rest_length = a;
        fr.bond = bond_material(o.required("material"), o.at("material"));
        br.quanta = fr.quanta = quanta_mask(o, w);
        out.emplace_back(std::move(br));
        out.emplace_back(std::move(fr));
      } else {
        bad(path + ".type", "unknown heuristic '" + type +
                                "' (accepted: break, plastic, ground, plane, sphere, box, contact, form, liquid)");
      }
    }
    return out;
  }

  // Quanta that share no bond but start closer than two contact radii would be pushed apart on
  // the first step: a radius too large for the lattice.
  void check_contact_radius(const QuantaContactRule& r, const Obj& o, const World& w) {
    std::unordered_set<std::uint64_t> bonded;
    for (std::size_t b = 0; b < w.num_bonds(); ++b) bonded.insert(pair_key(w.model.bond_i[b], w.model.bond_j[b]));
    for (const auto& [a, b] : pairs_within_radius(w.state.x, 2 * r.radius)) {
      if (bonded.count(pair_key(a, b))) continue;
      if (!r.same_body && w.model.body[a] == w.model.body[b]) continue;
      if (w.model.is_kinematic(a) && w.model.is_kinematic(b)) continue;
      const double d = (w.state.x[a] - w.state.x[b]).norm();
      if (d < 2 * r.radius)
        bad(o.at("radius"), "2 x radius = " + num_str(2 * r.radius) + " m exceeds the distance " + num_str(d) +
                                " m of quanta " + std::to_string(a) + " and " + std::to_string(b) +
                                ", which share no bond: they would be pushed apart at once");
    }
  }

  OutputSpec output(const json& j, std::uint64_t steps, const World& w) {
    Obj o(j, "output", {"dir", "every", "vtk", "checkpoint_every", "probes"});
    OutputSpec out;
    if (o.has("dir")) out.dir = string(o["dir"], o.at("dir"));
    if (out.dir.empty()) bad(o.at("dir"), "must not be empty");
    out.every = o.has("every") ? integer(o["every"], o.at("every"), 1) : std::max<std::uint64_t>(1, steps / 100);
    if (o.has("vtk")) out.vtk = boolean(o["vtk"], o.at("vtk"));
    if (o.has("checkpoint_every")) out.checkpoint_every = integer(o["checkpoint_every"], o.at("checkpoint_every"), 0);
    if (o.has("probes")) {
      const json& a = array(o["probes"], o.at("probes"));
      std::map<std::string, std::size_t> seen;
      for (std::size_t k = 0; k < a.size(); ++k) {
        Obj p(a[k], item(o.at("probes"), k), {"name", "select", "about"});
        ProbeSpec s;
        s.name = string(p.required("name"), p.at("name"));
        if (s.name.empty() || !std::all_of(s.name.begin(), s.name.end(), [](char c) {
              return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
            }))
          bad(p.at("name"), "must be letters, digits and '_' only (it names CSV columns), got '" + s.name + "'");
        if (auto [it, fresh] = seen.emplace(s.name, k); !fresh)
          bad(p.at("name"), "duplicate probe name '" + s.name + "' (also probes[" + std::to_string(it->second) + "])");
        s.quanta = selection(p.required("select"), p.at("select"), w);
        if (p.has("about")) s.about = vec3(p["about"], p.at("about"));
        out.probes.push_back(std::move(s));
      }
    }
    return out;
  }

  const json& root_;
  std::string default_name_;
  std::map<std::string, Material> materials_;
  std::map<std::string, Index> body_index_;
  SceneFiles files_;
  std::size_t obstacles_ = 0;  // obstacles numbered so far (their Obstacle::record)
};

/// Parses JSON, refusing duplicate keys (the JSON library would keep the last one silently).
json parse_strict(std::string_view text) {
  struct Level {
    explicit Level(bool a) : array(a) {}
    bool array;
    std::size_t index = 0;
    std::string key;
    std::unordered_set<std::string> keys;
  };
  std::vector<Level> stack;
  auto path = [&] {
    std::string p;
    for (std::size_t d = 0; d + 1 < stack.size(); ++d)
      p += stack[d].array ? "[" + std::to_string(stack[d].index) + "]" : (p.empty() ? "" : ".") + stack[d].key;
    return p;
  };
  auto element_done = [&] {
    if (!stack.empty() && stack.back().array) ++stack.back().index;
  };
  using E = json::parse_event_t;
  return json::parse(text, [&](int, E e, json& parsed) {
    switch (e) {
      case E::object_start: stack.emplace_back(false); break;
      case E::array_start: stack.emplace_back(true); break;
      case E::key: {
        Level& l = stack.back();
        l.key = parsed.get<std::string>();
        if (!l.keys.insert(l.key).second) {
          stack.emplace_back(false);  // so that path() includes this key
          bad(path(), "duplicate key (JSON would silently keep only the last one)");
        }
        break;
      }
      case E::object_end:
      case E::array_end:
        stack.pop_back();
        element_done();
        break;
      case E::value: element_done(); break;
    }
    return true;
  });
}

}  // namespace

Scene parse_scene(std::string_view text, const std::string& source, const SceneFiles& files) {
  try {
    json root;
    try {
      root = parse_strict(text);
    } catch (const json::parse_error& e) {
      throw SceneError(source, "", std::string("invalid JSON: ") + e.what());
    }
    if (!root.is_object()) throw SceneError(source, "", "a scene is a JSON object, got " + type_name(root));
    return Builder(root, std::filesystem::path(source).stem().string(), files).build();
  } catch (const Bad& b) {
    throw SceneError(source, b.path, b.rule);
  }
}

Scene load_scene(const std::filesystem::path& file) {
  std::string text;
  try {
    text = read_file(file);
  } catch (const std::exception& e) {
    throw SceneError(file.string(), "", e.what());
  }
  return parse_scene(text, file.string(), {.dir = file.parent_path()});
}

double explicit_step_hint(const World& w) {
  const Model& m = w.model;
  std::vector<double> k_sum(m.num_quanta(), 0.0);
  for (std::size_t b = 0; b < m.num_bonds(); ++b) {
    if (!w.state.alive[b]) continue;
    const double k = m.law[b] == Law::linear ? m.stiffness[b] : m.stiffness[b] / (m.eps[b] * m.eps[b]);
    k_sum[m.bond_i[b]] += k;
    k_sum[m.bond_j[b]] += k;
  }
  double w2 = 0;
  for (std::size_t i = 0; i < m.num_quanta(); ++i) w2 = std::max(w2, 2 * k_sum[i] * m.inv_mass[i]);
  return w2 > 0 ? 2 / std::sqrt(w2) : INFINITY;
}

std::string scene_summary(const Scene& s) {
  const World& w = s.world;
  const Model& m = w.model;
  std::size_t kinematic = 0;
  double mass = 0;
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  for (std::size_t i = 0; i < m.num_quanta(); ++i) {
    kinematic += m.is_kinematic(static_cast<Index>(i));
    mass += m.mass[i];
    lo = lo.cwiseMin(w.state.x[i]);
    hi = hi.cwiseMax(w.state.x[i]);
  }
  const double hint = explicit_step_hint(w);
  std::ostringstream o;
  o.precision(6);
  o << "  scene      " << s.name << (s.description.empty() ? "" : ": " + s.description) << "\n"
    << "  quanta     " << m.num_quanta() << " (" << m.num_quanta() - kinematic << " free, " << kinematic
    << " anchored or prescribed)\n"
    << "  bonds      " << m.num_bonds() << "\n"
    << "  bodies     " << m.body_names.size() << "\n"
    << "  mass       " << mass << " kg\n"
    << "  box        [" << lo.x() << ", " << lo.y() << ", " << lo.z() << "] .. [" << hi.x() << ", " << hi.y() << ", "
    << hi.z() << "] m\n"
    << "  timestep   " << s.timestep << " s x " << s.steps << " steps = " << s.timestep * static_cast<double>(s.steps)
    << " s, integrator " << to_string(s.integrator.type) << "\n"
    << "  explicit   stable below h = " << hint << " s (symplectic Euler, undamped); this step is "
    << s.timestep / hint << " x that";
  return o.str();
}

}  // namespace qbond
