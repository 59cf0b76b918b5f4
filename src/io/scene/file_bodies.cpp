// Builder: the body types read from other programs' files: tetrahedral meshes (Gmsh, VTK), CSV
// tables of quanta and bonds, and LAMMPS data files.
#include <numeric>

#include "io/scene/body_entry.hpp"
#include "qbond/builders/csv_table.hpp"
#include "qbond/builders/tet_mesh.hpp"
#include "qbond/io/lammps_data.hpp"

namespace qbond::scene_detail {

namespace {

/// A file's contents read by `parse`, its errors (file and line) reported at the body's key.
template <class Parse>
auto parsed(const std::string& path, Parse parse) {
  try {
    return parse();
  } catch (const std::runtime_error& e) {
    bad(path, e.what());
  }
}

}  // namespace

std::vector<Index> BodyEntry::tet_mesh() const {
  const std::string file = string(req("file"), at("file"));
  if (!is_tet_mesh_file(file))
    bad(at("file"), "unknown tetrahedral mesh format '" + std::filesystem::path(file).extension().string() +
                        "' (accepted: .msh, .vtu)");
  const double scale = j.contains("scale") ? positive(j["scale"], at("scale")) : 1.0;
  if (mat->youngs_modulus > 0)
    bad(at("material"), "a modulus calibrates lattices and chains, which have an elasticity theory; give a "
                        "tet_mesh's material a 'stiffness'");
  const bool by_density = mat->density > 0;
  if (by_density && j.contains("total_mass"))
    bad(path, "the mass comes from the density of material '" + j["material"].get<std::string>() +
                  "'; drop 'total_mass'");
  if (!by_density && !j.contains("total_mass"))
    bad(path, "the mass needs a material with a 'density' or the body's 'total_mass'");
  const double total_mass = by_density ? 0.0 : positive(j["total_mass"], at("total_mass"));
  // Named references, not a structured binding: clang before 16 cannot capture one in a lambda.
  const std::pair<std::string, std::string> read_bytes = builder.scene_file(file, at("file"));
  const std::string &bytes = read_bytes.first, &resolved = read_bytes.second;
  TetMesh mesh = parsed(at("file"), [&] { return parse_tet_mesh(bytes, file); });
  if (scale != 1)
    for (Vec3& x : mesh.nodes) x *= scale;
  const auto edges = tet_edges(mesh);
  too_many(static_cast<double>(mesh.nodes.size()));
  builder.plan_memory(at("file"), static_cast<double>(mesh.nodes.size()), static_cast<double>(edges.size()));
  // Lumped masses: each tetrahedron gives a quarter of its mass to each of its nodes.
  const std::vector<double> volume = lumped_volumes(mesh);
  const double mesh_volume = std::accumulate(volume.begin(), volume.end(), 0.0);
  const double density = by_density ? mat->density : total_mass / mesh_volume;
  std::vector<Index> ids;
  ids.reserve(mesh.nodes.size());
  for (std::size_t k = 0; k < mesh.nodes.size(); ++k)
    ids.push_back(w.add_quanta(mesh.nodes[k], Vec3::Zero(), density * volume[k], id, volume[k]));
  for (const auto& [a, b] : edges) w.add_bond(ids[a], ids[b], mat->bond);
  res["file"] = resolved;
  res["scale"] = scale;
  return ids;
}

std::vector<Index> BodyEntry::csv() const {
  const std::string qfile = string(req("quanta"), at("quanta"));
  const std::pair<std::string, std::string> read_qbytes = builder.scene_file(qfile, at("quanta"));
  const std::string &qbytes = read_qbytes.first, &qresolved = read_qbytes.second;
  const CsvQuanta q = parsed(at("quanta"), [&] { return parse_quanta_csv(qbytes, qfile); });
  too_many(static_cast<double>(q.x.size()));
  const bool column = !q.mass.empty();
  if (column == j.contains("mass"))
    bad(path, column ? "the quanta table has a mass column; drop 'mass'"
                     : "the quanta table has no mass column: give 'mass' (kg, each quanta)");
  const double mass = column ? 0.0 : positive(j["mass"], at("mass"));
  const double vol = j.contains("volume") ? positive(j["volume"], at("volume")) : 0.0;
  CsvBonds b;
  std::string bresolved;
  if (j.contains("bonds")) {
    const std::string bfile = string(j["bonds"], at("bonds"));
    const std::pair<std::string, std::string> read_bbytes = builder.scene_file(bfile, at("bonds"));
    const std::string &bbytes = read_bbytes.first, &where = read_bbytes.second;
    b = parsed(at("bonds"), [&] { return parse_bonds_csv(bbytes, bfile, q.x.size()); });
    bresolved = where;
    if (b.material.empty() && !j.contains("bond_material"))
      bad(at("bond_material"), "required: the bond table has no material column");
  } else if (j.contains("bond_material")) {
    bad(at("bond_material"), "there is no 'bonds' table for it");
  }
  builder.plan_memory(at("quanta"), static_cast<double>(q.x.size()), static_cast<double>(b.ends.size()));
  const BondSpec fallback =
      j.contains("bond_material") ? builder.bond_material(j["bond_material"], at("bond_material")) : BondSpec{};
  std::vector<Index> ids;
  ids.reserve(q.x.size());
  for (std::size_t k = 0; k < q.x.size(); ++k)
    ids.push_back(w.add_quanta(q.x[k], q.v.empty() ? Vec3::Zero() : q.v[k], column ? q.mass[k] : mass, id, vol));
  for (std::size_t k = 0; k < b.ends.size(); ++k) {
    const BondSpec spec = b.material.empty() ? fallback : builder.bond_material(json(b.material[k]), at("bonds") + " (bond " + std::to_string(k) + "'s material)");
    w.add_bond(ids[b.ends[k].first], ids[b.ends[k].second], spec);
  }
  res["quanta"] = qresolved;
  if (!bresolved.empty()) res["bonds"] = bresolved;
  return ids;
}

std::vector<Index> BodyEntry::lammps() const {
  const std::string file = string(req("file"), at("file"));
  std::optional<AtomStyle> style;
  if (j.contains("atom_style"))
    style = choice<AtomStyle>(j["atom_style"], at("atom_style"),
                              {{"atomic", AtomStyle::atomic},
                               {"bond", AtomStyle::bond},
                               {"molecular", AtomStyle::molecular},
                               {"full", AtomStyle::full}});
  const double vol = j.contains("volume") ? positive(j["volume"], at("volume")) : 0.0;
  const std::pair<std::string, std::string> read_bytes = builder.scene_file(file, at("file"));
  const std::string &bytes = read_bytes.first, &resolved = read_bytes.second;
  const LammpsData d = parsed(at("file"), [&] { return parse_lammps_data(bytes, file, style ? &*style : nullptr); });
  too_many(static_cast<double>(d.x.size()));
  builder.plan_memory(at("file"), static_cast<double>(d.x.size()), static_cast<double>(d.bond_ends.size()));
  // Bond type t takes bond_materials[t − 1].
  std::vector<BondSpec> type_bond;
  if (d.bond_types > 0) {
    if (!j.contains("bond_materials"))
      bad(at("bond_materials"), "required: the file has " + std::to_string(d.bond_types) +
                                    " bond type(s); list one material name for each, in type order");
    const json& names = array(j["bond_materials"], at("bond_materials"));
    if (names.size() != static_cast<std::size_t>(d.bond_types))
      bad(at("bond_materials"), "expected " + std::to_string(d.bond_types) + " material names (one per bond type), got " +
                                    std::to_string(names.size()));
    for (std::size_t t = 0; t < names.size(); ++t)
      type_bond.push_back(builder.bond_material(names[t], item(at("bond_materials"), t)));
  } else if (j.contains("bond_materials")) {
    bad(at("bond_materials"), "the file has no bond types");
  }
  std::vector<Index> ids;
  ids.reserve(d.x.size());
  for (std::size_t k = 0; k < d.x.size(); ++k)
    ids.push_back(w.add_quanta(d.x[k], d.v[k], d.type_mass[static_cast<std::size_t>(d.atom_type[k] - 1)], id, vol));
  for (std::size_t k = 0; k < d.bond_ends.size(); ++k)
    w.add_bond(ids[d.bond_ends[k].first], ids[d.bond_ends[k].second],
               type_bond[static_cast<std::size_t>(d.bond_type[k] - 1)]);
  res["file"] = resolved;
  // What the file holds that qbond does not read (angles, coefficients) is said in the resolved
  // scene's notes, unless the body has its own.
  if (!d.ignored.empty() && !j.contains("notes")) {
    std::string list;
    for (const auto& s : d.ignored) list.append(list.empty() ? "" : ", ").append(s);
    res["notes"] = "sections of the data file not read: " + list;
  }
  return ids;
}

}  // namespace qbond::scene_detail
