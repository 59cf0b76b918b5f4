#pragma once
/// Irregular bodies (docs/geometry.md): Poisson-disk or random point packings bonded
/// within a radius (the paper's Figure 12 asymmetric structures), and closed triangle meshes
/// (OBJ, STL) voxelised into a simple-cubic lattice.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "qbond/builders/builders.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

/// What a builder does with points that end up with no bond (they would fly off on their own).
enum class Isolated : std::uint8_t {
  drop,   ///< leave them out of the body (ids stay consecutive)
  keep,   ///< keep them as free quanta
  error,  ///< throw std::invalid_argument naming how many there are and the first one
};

/// Points in the box [0, size] bonded to every other point at most `bond_radius` away.
/// With size.z() == 0 the points lie in the xy plane (2D).
struct PointPacking {
  enum Kind : std::uint8_t {
    poisson,  ///< Bridson's Poisson-disk sampling: no two points closer than min_distance, no room left
    random,   ///< `count` uniform points (with min_distance > 0: darts closer than it are thrown again)
  };
  Kind kind = poisson;
  Vec3 size = Vec3(0.1, 0.1, 0.1);  ///< box extents [m]; x, y > 0, z >= 0 (0: 2D)
  double min_distance = 0.01;       ///< [m]; poisson: > 0; random: >= 0 (0: no rejection)
  std::size_t count = 0;            ///< random: the number of points (> 0); poisson: a cap (0: fill the box)
  double bond_radius = 0.015;       ///< bond every pair at most this far apart [m]
  double quanta_mass = 1e-3;        ///< [kg]
  BondSpec bond;                    ///< law, stiffness, damping; rest length = initial distance
  std::uint64_t seed = 1;           ///< same seed, same points (on every platform: qbond's own Rng)
  Isolated isolated = Isolated::drop;
};

/// The packing's points, in the order they were accepted. Deterministic for a seed: only the
/// SplitMix64 generator, +, ×, sqrt and comparisons are used (no libm or std:: distributions).
/// Throws std::invalid_argument on bad parameters, or when a random packing with min_distance
/// cannot place `count` points.
std::vector<Vec3> sample_points(const PointPacking& spec);

/// Upper bound on the points a packing can make: the spheres (discs) of diameter min_distance
/// about the points are disjoint and fit in the box grown by min_distance/2, at most at the
/// densest packing's fraction. For refusing absurd sizes before sampling.
double max_points(const PointPacking& spec);

/// Every pair (i, j), i < j, with |x_i − x_j| <= radius, sorted; found with a uniform grid of
/// cell `radius` (cost linear in the points for bounded density).
std::vector<std::pair<Index, Index>> pairs_within_radius(const std::vector<Vec3>& x, double radius);

/// Adds the packing to `world` as body `body`: its points (minus isolated ones when dropped)
/// in sampling order, bonded in sorted pair order. Returns the ids of its quanta.
std::vector<Index> add_point_packing(World& world, const PointPacking& spec, Index body = 0);

/// An indexed triangle mesh [m].
struct TriangleMesh {
  std::vector<Vec3> vertices{};
  std::vector<std::array<Index, 3>> triangles{};  ///< vertex ids of each triangle
};

/// Reads a Wavefront OBJ file: `v x y z [w]` and `f` lines (`a`, `a/t`, `a//n`, `a/t/n`,
/// 1-based, negative = relative to the last vertex); polygons are fan-triangulated; every other
/// line is ignored. Throws std::runtime_error "FILE:LINE: rule" on a malformed file.
TriangleMesh read_obj(const std::filesystem::path& file);
/// Reads an STL file, binary (size 84 + 50 n) or ASCII (`solid` … `endsolid`); vertices with
/// identical coordinates are merged. Throws std::runtime_error "FILE[:LINE]: rule".
TriangleMesh read_stl(const std::filesystem::path& file);
/// read_obj or read_stl by the extension (.obj, .stl, any case).
TriangleMesh read_mesh(const std::filesystem::path& file);
/// read_obj on a file's contents (e.g. a mesh compiled in); `name` stands for the file in messages.
TriangleMesh parse_obj(std::string_view text, const std::string& name);
/// read_stl on a file's contents; `name` stands for the file in messages.
TriangleMesh parse_stl(std::string_view bytes, const std::string& name);
/// parse_obj or parse_stl by the extension of `name`.
TriangleMesh parse_mesh(std::string_view bytes, const std::string& name);

/// Throws std::runtime_error "NAME: ..." unless the mesh is closed: at least one triangle, no
/// triangle with a repeated vertex, and every edge shared by exactly two triangles.
void check_closed(const TriangleMesh& mesh, const std::string& name);

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
