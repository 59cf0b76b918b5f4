#pragma once
/// Closed triangle meshes voxelised into a simple-cubic lattice (docs/geometry.md).
#include <array>
#include <cstdint>
#include <vector>

#include "qbond/builders/builders.hpp"
#include "qbond/builders/mesh_reader.hpp"
#include "qbond/builders/sampling.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

/// A closed mesh filled with a simple-cubic lattice: the sites are the centres of the cells of a
/// grid of spacing a centred on the scaled mesh's bounding box (n_d = ⌈extent_d / a⌉ cells per
/// axis), kept when inside the mesh (ray parity); sites inside are bonded to the neighbour shells
/// as add_cubic_lattice does. Positions are in the mesh's frame (vertices × scale).
struct MeshLattice {
  TriangleMesh mesh;
  double scale = 1;       ///< multiplies the mesh's coordinates (e.g. 0.001 for millimetres)
  double spacing = 0.01;  ///< a [m]
  Shells shells = Shells::face_diagonal;
  double quanta_mass = 1e-3;  ///< [kg]
  BondSpec bond;
  Isolated isolated = Isolated::drop;
};

/// The grid of a mesh lattice: cells per axis, and the centre of cell (0, 0, 0) [m].
struct MeshGrid {
  std::array<std::int64_t, 3> cells{};
  Vec3 first = Vec3::Zero();
};
/// The grid `spec` fills (without filling it: for refusing absurd sizes first).
MeshGrid mesh_grid(const MeshLattice& spec);

/// Whether each site of the grid is inside the closed mesh (sites x fastest, then y, then z).
/// Ray parity along +x per grid row, with exact tie-breaking (simulation of simplicity) so a ray
/// through an edge or a vertex counts one crossing, never zero or two.
std::vector<std::uint8_t> inside_sites(const TriangleMesh& scaled_mesh, const MeshGrid& grid, double spacing);

/// Adds the voxelised mesh to `world` as body `body`; ids run x fastest, then y, then z over the
/// sites inside. Throws std::runtime_error if the mesh is not closed, std::invalid_argument on
/// bad parameters. Returns the ids of its quanta.
std::vector<Index> add_mesh_lattice(World& world, const MeshLattice& spec, Index body = 0);

}  // namespace qbond
