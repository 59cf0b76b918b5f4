// Tetrahedral meshes: the format by extension, the checks, the edges and the lumped volumes.
#include "qbond/builders/tet_mesh.hpp"

#include <algorithm>
#include <limits>

#include "io/text_fields.hpp"
#include "qbond/io/files.hpp"

namespace qbond {

namespace {

constexpr Index kUnused = std::numeric_limits<Index>::max();

/// Leaves out the nodes no tetrahedron uses (a Gmsh file's geometry points, say), keeping the
/// order of the others.
void drop_unused_nodes(TetMesh& mesh) {
  std::vector<Index> renumber(mesh.nodes.size(), kUnused);
  for (const auto& t : mesh.tets)
    for (Index v : t)
      if (v < renumber.size()) renumber[v] = 0;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < mesh.nodes.size(); ++i)
    if (renumber[i] != kUnused) {
      renumber[i] = static_cast<Index>(kept);
      mesh.nodes[kept++] = mesh.nodes[i];
    }
  mesh.nodes.resize(kept);
  for (auto& t : mesh.tets)
    for (Index& v : t)
      if (v < renumber.size()) v = renumber[v];
}

}  // namespace

bool is_tet_mesh_file(const std::string& name) {
  const std::string ext = text::lower_extension(name);
  return ext == ".msh" || ext == ".vtu";
}

TetMesh parse_tet_mesh(std::string_view bytes, const std::string& name) {
  const std::string ext = text::lower_extension(name);
  TetMesh mesh;
  if (ext == ".msh")
    mesh = parse_gmsh(bytes, name);
  else if (ext == ".vtu")
    mesh = parse_vtu(bytes, name);
  else
    throw std::runtime_error(name + ": unknown tetrahedral mesh format '" + ext + "' (accepted: .msh, .vtu)");
  drop_unused_nodes(mesh);
  check_tets(mesh, name);
  return mesh;
}

TetMesh read_tet_mesh(const std::filesystem::path& file) { return parse_tet_mesh(read_file(file), file.string()); }

double tet_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return std::abs((b - a).dot((c - a).cross(d - a))) / 6;
}

std::vector<std::pair<Index, Index>> tet_edges(const TetMesh& mesh) {
  std::vector<std::pair<Index, Index>> edges;
  edges.reserve(6 * mesh.tets.size());
  for (const auto& t : mesh.tets)
    for (std::size_t a = 0; a < 4; ++a)
      for (std::size_t b = a + 1; b < 4; ++b) edges.emplace_back(std::min(t[a], t[b]), std::max(t[a], t[b]));
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  return edges;
}

std::vector<double> lumped_volumes(const TetMesh& mesh) {
  std::vector<double> v(mesh.nodes.size(), 0.0);
  for (const auto& t : mesh.tets) {
    const double quarter =
        tet_volume(mesh.nodes[t[0]], mesh.nodes[t[1]], mesh.nodes[t[2]], mesh.nodes[t[3]]) / 4;
    for (Index i : t) v[i] += quarter;
  }
  return v;
}

void check_tets(const TetMesh& mesh, const std::string& name) {
  if (mesh.tets.empty()) text::malformed(name, 0, "the mesh has no tetrahedra");
  std::vector<std::uint8_t> used(mesh.nodes.size(), 0);
  for (std::size_t k = 0; k < mesh.tets.size(); ++k) {
    const auto& t = mesh.tets[k];
    const std::size_t line = k < mesh.tet_line.size() ? mesh.tet_line[k] : 0;
    const std::string which = "tetrahedron " + std::to_string(k);
    for (Index v : t)
      if (v >= mesh.nodes.size()) text::malformed(name, line, which + " names a missing node");
    for (std::size_t a = 0; a < 4; ++a)
      for (std::size_t b = a + 1; b < 4; ++b)
        if (t[a] == t[b]) text::malformed(name, line, which + " names a node twice");
    if (!(tet_volume(mesh.nodes[t[0]], mesh.nodes[t[1]], mesh.nodes[t[2]], mesh.nodes[t[3]]) > 0))
      text::malformed(name, line, which + " has zero volume (its four nodes lie in a plane)");
    for (Index v : t) used[v] = 1;
  }
  if (const auto it = std::find(used.begin(), used.end(), 0); it != used.end())
    text::malformed(name, 0, "node " + std::to_string(it - used.begin()) + " belongs to no tetrahedron");
}

}  // namespace qbond
