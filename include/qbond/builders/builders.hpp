#pragma once
/// Builders: lay out quanta and bonds of common structures into a World.
#include <array>
#include <vector>

#include "qbond/model/world.hpp"

namespace qbond {

/// Which neighbour shells of a simple-cubic lattice get bonds.
enum class Shells : std::uint8_t {
  nearest = 1,        ///< 6 neighbours at distance a
  face_diagonal = 2,  ///< + 12 at a√2
  body_diagonal = 3,  ///< + 8 at a√3
};

/// One site of a Bravais lattice as the builders lay its bonds and lattice elasticity
/// (materials.hpp) counts them: half of each neighbour shell (so every pair is bonded once) as
/// integer offsets in units of `unit` × spacing, and the volume a site stands for, in spacing³
/// (for 2D lattices: area per site in spacing², times the sheet's thickness).
struct LatticeCell {
  std::vector<std::array<int, 3>> offsets;
  double unit = 1;
  double site_volume = 1;
  int dims = 3;
};
/// Simple cubic with the given shells.
LatticeCell cubic_cell(Shells shells);
/// Face-centred cubic, spacing = the cubic cell's side (offsets in half spacings, 4 sites a cell).
LatticeCell fcc_cell(bool second_shell);
/// 2D square in the xy plane.
LatticeCell square_cell(bool diagonals, bool bending);

/// A simple-cubic block of size[0]×size[1]×size[2] quanta.
struct CubicLattice {
  std::array<int, 3> size{2, 2, 2};
  double spacing = 0.01;       ///< a [m]
  double quanta_mass = 1e-3;   ///< [kg]
  Vec3 origin = Vec3::Zero();  ///< position of quanta (0,0,0) [m]
  Vec3 velocity = Vec3::Zero();
  Shells shells = Shells::face_diagonal;
  BondSpec bond;  ///< law, stiffness, damping of every bond; rest length = initial distance
};

/// Adds the lattice to `world` as body `body`; quanta ids run x fastest, then y, then z.
/// Returns the ids of its quanta.
std::vector<Index> add_cubic_lattice(World& world, const CubicLattice& spec, Index body = 0);

/// A straight chain of `count` quanta from `start` to `end`, consecutive ones bonded.
struct Chain {
  int count = 2;
  Vec3 start = Vec3::Zero();
  Vec3 end = Vec3::UnitX();
  double quanta_mass = 1e-3;  ///< [kg]
  Vec3 velocity = Vec3::Zero();
  double area = -1;           ///< cross-section [m²], for quanta volumes; negative: segment²
  BondSpec bond;
};
std::vector<Index> add_chain(World& world, const Chain& spec, Index body = 0);

/// A 2D square lattice of size[0]×size[1] quanta in the xy plane (the paper's Figure 1), bonded to
/// the 4 nearest neighbours, with `diagonals` also to the 4 diagonal ones; `bending` adds bonds to
/// the second neighbours along rows and columns (distance 2a), which give a sheet bending
/// stiffness. Ids run x fastest.
struct SquareLattice {
  std::array<int, 2> size{2, 2};
  double spacing = 0.01;      ///< a [m]
  double quanta_mass = 1e-3;  ///< [kg]
  bool diagonals = true;
  bool bending = false;
  BondSpec bond;
  double thickness = -1;  ///< [m] of the sheet, for its quanta volumes; negative: the spacing
};
std::vector<Index> add_square_lattice(World& world, const SquareLattice& spec, Index body = 0);

/// A face-centred cubic block of cells[0]×cells[1]×cells[2] cubic cells of side a: every FCC
/// site inside [0, cells·a] per axis (corners and face centres, no duplicates), bonded to its 12
/// nearest neighbours (a/√2) and, with `second_shell`, to its 6 second neighbours (a). Ids follow
/// the sites sorted by z, then y, then x.
struct FccLattice {
  std::array<int, 3> cells{1, 1, 1};
  double spacing = 0.01;      ///< cubic cell side a [m]
  double quanta_mass = 1e-3;  ///< [kg]
  bool second_shell = false;
  BondSpec bond;
};
std::vector<Index> add_fcc_lattice(World& world, const FccLattice& spec, Index body = 0);

/// Where a body built at the origin goes, and how it moves.
struct Placement {
  Vec3 origin = Vec3::Zero();          ///< translation [m], applied after the rotation
  Vec3 axis = Vec3::UnitZ();           ///< rotation axis (unit)
  double angle = 0;                    ///< rotation angle about the body-frame origin [rad]
  Vec3 velocity = Vec3::Zero();        ///< velocity of the centre of mass [m/s]
  Vec3 angular_velocity = Vec3::Zero();  ///< [rad/s]: v_i = velocity + ω × (x_i − x_cm)
};
/// Rotates and translates the quanta `ids` (rest lengths are unchanged: the motion is rigid) and
/// gives them the rigid velocity field of the placement.
void place_body(World& world, const std::vector<Index>& ids, const Placement& p);

}  // namespace qbond
