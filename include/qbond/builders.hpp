#pragma once
/// Builders (DESIGN §7): lay out quanta and bonds of common structures into a World.
#include <array>
#include <vector>

#include "qbond/world.hpp"

namespace qbond {

/// Which neighbour shells of a simple-cubic lattice get bonds.
enum class Shells : std::uint8_t {
  nearest = 1,        ///< 6 neighbours at distance a
  face_diagonal = 2,  ///< + 12 at a√2
  body_diagonal = 3,  ///< + 8 at a√3
};

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
  BondSpec bond;
};
std::vector<Index> add_chain(World& world, const Chain& spec, Index body = 0);

}  // namespace qbond
