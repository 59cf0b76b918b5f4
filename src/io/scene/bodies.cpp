// Builder: the `bodies` section: lattices, sheets, chains, quanta, packings, meshes and gases.
#include "io/scene/body_entry.hpp"

#include <cmath>

#include "qbond/builders/builders.hpp"
#include "qbond/builders/gas.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/io/files.hpp"
#include "qbond/laws/materials.hpp"

namespace qbond::scene_detail {

// The body types of the `bodies` section, one row each: its type, what it makes, the keys it
// accepts (every body's placement keys first, in the order error messages list them) and its
// builder, which makes the body's quanta and bonds in the body's frame (body() then places them).
// Adding a body type is one row here; body_types() and the docs test read this table.
std::span<const Builder::BodyReader> Builder::body_readers() {
  // Every body takes the placement keys, then its type's own; a body of quanta given by a count
  // also takes its mass as one quanta's or the body's total.
  auto keys = [](std::initializer_list<SceneKey> own, bool massive = true) {
    std::vector<SceneKey> all = {{"name", "string"},   {"type", "string"},
                                 {"origin", "vec3"},   {"rotation", "@rotation"},
                                 {"velocity", "vec3"}, {"angular_velocity", "vec3"}};
    all.insert(all.end(), own);
    if (massive) all.insert(all.end(), {{"quanta_mass", "number"}, {"total_mass", "number"}});
    return all;
  };
  static const BodyReader rows[] = {
      {"lattice", "a square, cubic or FCC lattice of bonded quanta",
       keys({{"cell", "enum:square|cubic|fcc"},
             {"size", "array"},
             {"spacing", "number"},
             {"neighbors", "string"},
             {"thickness", "number"},
             {"material", "string"}}),
       [](const BodyEntry& e) { return e.lattice(); }},
      {"sheet", "a square lattice, optionally with bending bonds",
       keys({{"size", "array"},
             {"spacing", "number"},
             {"neighbors", "string"},
             {"bending", "boolean"},
             {"thickness", "number"},
             {"material", "string"}}),
       [](const BodyEntry& e) { return e.lattice(); }},
      {"chain", "quanta in a line, consecutive ones bonded",
       keys({{"start", "vec3"}, {"end", "vec3"}, {"count", "integer"}, {"area", "number"}, {"material", "string"}}),
       [](const BodyEntry& e) { return e.chain(); }},
      {"quanta", "quanta at given positions, no bonds", keys({{"positions", "array"},
             {"masses", "array"},
             {"mass", "number"},
             {"velocities", "array"},
             {"volume", "number"}},
            false),
       [](const BodyEntry& e) { return e.quanta(); }},
      {"packing", "irregular points bonded within a radius",
       keys({{"points", "string"},
             {"size", "array"},
             {"min_distance", "number"},
             {"count", "integer"},
             {"bond_radius", "number"},
             {"isolated", "enum:drop|keep|error"},
             {"seed", "integer"},
             {"material", "string"}}),
       [](const BodyEntry& e) {
         auto mass_of = [&e](double count, double calibrated) { return e.mass_of(count, calibrated); };
         return e.builder.packing_body(e.j, e.path, e.res, e.w, e.id, mass_of, *e.mat);
       }},
      {"mesh", "a closed OBJ/STL mesh filled with a simple-cubic lattice",
       keys({{"file", "string"},
             {"scale", "number"},
             {"spacing", "number"},
             {"neighbors", "string"},
             {"isolated", "enum:drop|keep|error"},
             {"material", "string"}}),
       [](const BodyEntry& e) {
         auto mass_of = [&e](double count, double calibrated) { return e.mass_of(count, calibrated); };
         return e.builder.mesh_body(e.j, e.path, e.res, e.w, e.id, mass_of, *e.mat);
       }},
      {"tet_mesh", "a tetrahedral mesh (Gmsh .msh, VTK .vtu): quanta at nodes, bonds on edges",
       keys({{"file", "string"}, {"scale", "number"}, {"material", "string"}, {"total_mass", "number"}}, false),
       [](const BodyEntry& e) { return e.tet_mesh(); }},
      {"csv", "quanta and bonds from CSV tables",
       keys({{"quanta", "string"},
             {"bonds", "string"},
             {"bond_material", "string"},
             {"mass", "number"},
             {"volume", "number"}},
            false),
       [](const BodyEntry& e) { return e.csv(); }},
      {"lammps", "atoms and bonds from a LAMMPS data file",
       keys({{"file", "string"},
             {"atom_style", "enum:atomic|bond|molecular|full"},
             {"bond_materials", "array"},
             {"volume", "number"}},
            false),
       [](const BodyEntry& e) { return e.lammps(); }},
      {"gas", "unbonded quanta with thermal velocities",
       keys({{"size", "array"},
             {"count", "integer"},
             {"min_distance", "number"},
             {"kT", "number"},
             {"speeds", "enum:maxwell|equal"},
             {"seed", "integer"}}),
       [](const BodyEntry& e) {
         auto mass_of = [&e](double count, double calibrated) { return e.mass_of(count, calibrated); };
         return e.builder.gas_body(e.j, e.path, e.res, e.w, e.id, mass_of);
       }},
  };
  return rows;
}

void Builder::bodies(const json& j, json& res, World& w) {
  if (!array(j, "bodies").size()) bad("bodies", "must hold at least one body");
  for (std::size_t k = 0; k < j.size(); ++k) body(j[k], item("bodies", k), res[k], w);
}

void Builder::body(const json& j, const std::string& path, json& res, World& w) {
  if (!j.is_object()) bad(path, "expected an object, got " + type_name(j));
  const std::string type = j.contains("type") ? string(j["type"], path + ".type") : "";
  const auto types = body_readers();
  const auto row = std::find_if(types.begin(), types.end(), [&](const BodyReader& r) { return type == r.type; });
  if (type.empty()) bad(path + ".type", "required key missing");
  if (row == types.end()) {
    std::vector<std::string> names;
    for (const BodyReader& r : types) names.emplace_back(r.type);
    bad(path + ".type", "unknown body type '" + type + "' (accepted: " + join(names) + ")");
  }
  const std::vector<const char*> accepted = keys_of("body." + type);
  for (const auto& [key, v] : j.items())
    if (std::find(accepted.begin(), accepted.end(), key) == accepted.end() &&
        !annotation(key, v, path + "." + key)) {
      std::vector<std::string> names(accepted.begin(), accepted.end());
      bad(path + "." + key, "unknown key for a " + type + " body (accepted: " + join(names) + ")");
    }
  auto at = [&](const char* key) { return path + "." + key; };
  if (!j.contains("name")) bad(at("name"), "required key missing");
  const std::string name = string(j["name"], at("name"));
  if (auto it = body_index_.find(name); it != body_index_.end())
    bad(at("name"), "duplicate body name '" + name + "' (also bodies[" + std::to_string(it->second) + "])");
  const Index id = w.add_body(name);
  body_index_[name] = id;

  // A material given by a modulus or a density fixes the bonds' stiffness or the quanta's
  // mass from the body's geometry (materials.hpp); the resolved scene records the numbers. A body
  // type that takes a material needs one (its row's keys say whether it does).
  const Material* mat = nullptr;
  if (std::find_if(accepted.begin(), accepted.end(), [](const char* k) { return std::string_view(k) == "material"; }) !=
      accepted.end()) {
    if (!j.contains("material")) bad(at("material"), "required key missing");
    mat = &material(j["material"], at("material"));
  }
  const std::vector<Index> ids = row->build(BodyEntry{*this, j, path, res, w, id, mat, type});
  // Placement: rotate, translate, then the rigid velocity field.
  Placement p;
  if (j.contains("origin")) p.origin = vec3(j["origin"], at("origin"));
  if (j.contains("rotation")) {
    Obj r(j["rotation"], at("rotation"), keys_of("rotation"));
    p.axis = direction(r.required("axis"), r.at("axis"));
    p.angle = number(r.required("angle"), r.at("angle"));
  }
  if (j.contains("velocity")) p.velocity = vec3(j["velocity"], at("velocity"));
  if (j.contains("angular_velocity")) p.angular_velocity = vec3(j["angular_velocity"], at("angular_velocity"));
  // Velocities a builder gave its quanta (a gas's thermal ones, a quanta body's `velocities`, a
  // file's) are kept: the placement's rigid field adds a drift to them.
  std::vector<Vec3> own;
  if (std::any_of(ids.begin(), ids.end(), [&](Index i) { return !w.state.v[i].isZero(); }))
    for (Index i : ids) own.push_back(w.state.v[i]);
  place_body(w, ids, p);
  for (std::size_t k = 0; k < own.size(); ++k) w.state.v[ids[k]] += own[k];
  res["origin"] = {p.origin.x(), p.origin.y(), p.origin.z()};
  res["velocity"] = {p.velocity.x(), p.velocity.y(), p.velocity.z()};
  res["angular_velocity"] = {p.angular_velocity.x(), p.angular_velocity.y(), p.angular_velocity.z()};
}

Isolated Builder::isolated(const json& j, const std::string& path, json& res) {
  const Isolated v = j.contains("isolated") ? choice<Isolated>(j["isolated"], path + ".isolated",
                                                               {{"drop", Isolated::drop},
                                                                {"keep", Isolated::keep},
                                                                {"error", Isolated::error}})
                                            : Isolated::drop;
  res["isolated"] = v == Isolated::drop ? "drop" : v == Isolated::keep ? "keep" : "error";
  return v;
}

template <class MassOf>
void Builder::set_masses(World& w, const std::vector<Index>& ids, const MassOf& mass_of, const Material& mat,
                         double volume) {
  const double m = mass_of(static_cast<double>(ids.size()), mat.density * volume);
  for (Index i : ids) {
    w.model.mass[i] = m;
    w.model.inv_mass[i] = 1 / m;
    w.model.volume[i] = volume;
  }
}

template <class MassOf>
std::vector<Index> Builder::gas_body(const json& j, const std::string& path, json& res, World& w, Index id,
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
  plan_memory(at("count"), static_cast<double>(n), 0);
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

template <class MassOf>
std::vector<Index> Builder::packing_body(const json& j, const std::string& path, json& res, World& w,
                                         Index id, const MassOf& mass_of, const Material& mat) {
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
  // A Poisson-disk packing without a count is planned at its most points (packing.hpp's bound),
  // so that an unreasonably large one is refused before it is sampled.
  plan_memory(at(j.contains("count") ? "count" : "min_distance"),
              j.contains("count") ? static_cast<double>(p.count) : max_points(p), 0);
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
  p.max_bonds = bonds_left();
  std::vector<Index> ids;
  try {
    ids = add_point_packing(w, p, id);
  } catch (const std::invalid_argument& e) {
    bad(path, e.what());
  } catch (const std::length_error& e) {
    bad(at("bond_radius"), std::string(e.what()) + ": more bonds than the memory limit holds");
  }
  plan_memory(at("bond_radius"), 0, static_cast<double>(w.num_bonds()));
  if (ids.empty())
    bad(at("bond_radius"), "no two points lie within " + num_str(p.bond_radius) + " m: every point is isolated");
  // Each point stands for the box's volume over the points (a flat packing: a layer one mean
  // spacing thick).
  const double per = p.size.x() * p.size.y() / static_cast<double>(ids.size());
  set_masses(w, ids, mass_of, mat, p.size.z() > 0 ? per * p.size.z() : per * std::sqrt(per));
  res["points"] = poisson ? "poisson" : "random";
  res["size"] = json::array({p.size.x(), p.size.y(), p.size.z()});
  res["min_distance"] = p.min_distance;
  res["count"] = p.count;
  res["seed"] = p.seed;
  return ids;
}

std::pair<std::string, std::string> Builder::scene_file(const std::string& file, const std::string& path) {
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

template <class MassOf>
std::vector<Index> Builder::mesh_body(const json& j, const std::string& path, json& res, World& w, Index id,
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
  plan_memory(at("spacing"), sites, 0);
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


// ---- What the body types share (body_entry.hpp) ----------------------------------------------

const json& BodyEntry::req(const char* key) const {
  if (!j.contains(key)) bad(path + "." + key, "required key missing");
  return j[key];
}

std::pair<std::array<int, 3>, double> BodyEntry::sizes(std::size_t dims) const {
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
}

double BodyEntry::mass_of(double count, double calibrated) const {
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
}

BondSpec BodyEntry::lattice_bond(const LatticeCell& cell, double a, double thickness) const {
  BondSpec bond = mat->bond;
  if (mat->youngs_modulus > 0) {
    bond.stiffness = calibrated_stiffness(cell, mat->youngs_modulus, a, thickness);
    res["stiffness"] = bond.stiffness;
  }
  return bond;
}

double BodyEntry::lattice_mass(const LatticeCell& cell, double a, double thickness) const {
  return mat->density > 0 ? calibrated_mass(cell, mat->density, a, thickness) : 0.0;
}

void BodyEntry::too_many(double count) const {
  if (count > kMaxQuanta)
    bad(at("size"), "would make " + num_str(count) + " quanta (limit " + num_str(kMaxQuanta) + ")");
}

void BodyEntry::plan_lattice(double count, const LatticeCell& c) const {
  builder.plan_memory(at("size"), count, count * static_cast<double>(c.offsets.size()));
}

double BodyEntry::thickness(double a, bool square) const {
  if (!j.contains("thickness")) return a;
  if (!square) bad(at("thickness"), "only square (2D) cells have a thickness");
  return positive(j["thickness"], at("thickness"));
}

std::vector<Index> BodyEntry::lattice() const {
  std::vector<Index> ids;
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
    plan_lattice(count, c);
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
    plan_lattice(count, c);
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
    plan_lattice(count, c);
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
  return ids;
}

std::vector<Index> BodyEntry::chain() const {
  std::vector<Index> ids;
  Chain c;
  c.start = vec3(req("start"), at("start"));
  c.end = vec3(req("end"), at("end"));
  if (!((c.end - c.start).norm() > 0)) bad(at("end"), "must differ from start");
  const auto count = integer(req("count"), at("count"), 2);
  too_many(static_cast<double>(count));
  builder.plan_memory(at("count"), static_cast<double>(count), static_cast<double>(count - 1));
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
  return ids;
}

std::vector<Index> BodyEntry::quanta() const {
  std::vector<Index> ids;
  const json& pos = array(req("positions"), at("positions"));
  if (pos.empty()) bad(at("positions"), "must hold at least one position");
  too_many(static_cast<double>(pos.size()));
  builder.plan_memory(at("positions"), static_cast<double>(pos.size()), 0);
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
  // Each quanta's own velocity, kept when the body is placed (its rigid velocity adds to it).
  if (j.contains("velocities")) {
    const json& vs = j["velocities"];
    if (!vs.is_array() || vs.size() != ids.size())
      bad(at("velocities"), "expected an array of " + std::to_string(ids.size()) + " velocities (one per position)");
    for (std::size_t k = 0; k < ids.size(); ++k) w.state.v[ids[k]] = vec3(vs[k], item(at("velocities"), k));
  }
  return ids;
}

}  // namespace qbond::scene_detail

namespace qbond {

const std::vector<SceneType>& body_types() {
  static const std::vector<SceneType> types = scene_detail::Builder::scene_types(scene_detail::Builder::body_readers());
  return types;
}

}  // namespace qbond
