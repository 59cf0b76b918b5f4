#pragma once
/// Tetrahedral volume meshes read from Gmsh (.msh) and VTK (.vtu) files (docs/scene-format.md,
/// `tet_mesh` bodies): quanta at the nodes, bonds on the tetrahedra's edges, masses lumped from
/// the tetrahedra's volumes.
#include <array>
#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "qbond/core/math.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

/// A linear tetrahedral mesh [m]: nodes and four-node tetrahedra.
struct TetMesh {
  std::vector<Vec3> nodes{};
  std::vector<std::array<Index, 4>> tets{};  ///< node ids of each tetrahedron
  std::vector<std::size_t> tet_line{};       ///< the file line each tetrahedron was read from (messages)
};

/// Reads a Gmsh mesh in the ASCII formats 2.2 and 4.1: `$Nodes` and the four-node tetrahedra
/// (element type 4) of `$Elements`. Points, lines and triangles (the mesh's physical boundary
/// groups) are skipped; other volume elements (second-order tetrahedra, hexahedra, prisms,
/// pyramids) are refused, as is the binary format. Nodes no tetrahedron uses are left out.
/// Throws std::runtime_error "NAME:LINE: rule" on a malformed file.
TetMesh parse_gmsh(std::string_view text, const std::string& name);
/// Reads a VTK XML UnstructuredGrid (.vtu) with ASCII data arrays: its `Points` and the tetra
/// cells (VTK type 10) of `Cells` (`connectivity`, `offsets`, `types`). Vertex, line, triangle and
/// quad cells are skipped; other volume cells are refused, as are binary and appended data.
/// Throws std::runtime_error "NAME:LINE: rule".
TetMesh parse_vtu(std::string_view text, const std::string& name);
/// parse_gmsh (.msh) or parse_vtu (.vtu) by the extension of `name`, then check_tets.
TetMesh parse_tet_mesh(std::string_view bytes, const std::string& name);
/// parse_tet_mesh on a file's contents.
TetMesh read_tet_mesh(const std::filesystem::path& file);
/// Whether `name`'s extension (any case) is one parse_tet_mesh reads.
bool is_tet_mesh_file(const std::string& name);

/// Volume of the tetrahedron abcd, |(b − a) · ((c − a) × (d − a))| / 6 [m³].
double tet_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);
/// The unique edges of the mesh's tetrahedra as (smaller, larger) node ids, sorted.
std::vector<std::pair<Index, Index>> tet_edges(const TetMesh& mesh);
/// Each node's share of the mesh volume: V_i = Σ over its tetrahedra of V_t / 4 (lumped), so
/// that Σ V_i is the mesh volume and ρ V_i the node's mass.
std::vector<double> lumped_volumes(const TetMesh& mesh);
/// Throws std::runtime_error "NAME:LINE: ..." unless the mesh has a tetrahedron, every tetrahedron
/// names four distinct existing nodes and has a volume > 0, and every node belongs to one.
void check_tets(const TetMesh& mesh, const std::string& name);

}  // namespace qbond
