#pragma once
/// Point packings (docs/geometry.md): Poisson-disk or random points in a box, bonded within a
/// radius (the paper's Figure 12 asymmetric structures).
#include <cstddef>
#include <cstdint>
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
  std::size_t max_bonds = SIZE_MAX;  ///< more pairs within bond_radius: refused before they are stored
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
/// cell `radius` (cost linear in the points for bounded density). Throws std::length_error as
/// soon as more than `max_pairs` pairs are found, so that a radius far too large costs no more.
std::vector<std::pair<Index, Index>> pairs_within_radius(const std::vector<Vec3>& x, double radius,
                                                         std::size_t max_pairs = SIZE_MAX);

/// Adds the packing to `world` as body `body`: its points (minus isolated ones when dropped)
/// in sampling order, bonded in sorted pair order. Returns the ids of its quanta.
std::vector<Index> add_point_packing(World& world, const PointPacking& spec, Index body = 0);

}  // namespace qbond
