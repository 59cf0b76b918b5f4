#pragma once
/// Gases (docs/gases.md): unbonded quanta at random, non-overlapping positions with thermal
/// velocities. They collide with each other (QuantaContactRule) and with a container
/// (Obstacle::inside), whose recorded impulse measures their pressure.
///
/// Temperature is given as the thermal energy k_B T [J] (k_B = 1): a quanta stands for a lump of
/// matter, not a molecule, and with SI's k_B a 1 g quanta at 1 m/s would be at 10^20 K. For real
/// molecules T [K] = kT / 1.380649e-23.
#include <cstdint>
#include <span>
#include <vector>

#include "qbond/model/world.hpp"

namespace qbond {

/// A gas of `count` quanta in the box [0, size] (their centres), before placement.
struct Gas {
  /// How the speeds start.
  enum class Speeds : std::uint8_t {
    maxwell,  ///< Maxwell–Boltzmann: each velocity component normal with variance kT/m
    equal,    ///< every quanta at speed sqrt(3 kT / m) in a random direction (far from equilibrium)
  };
  Vec3 size = Vec3(0.1, 0.1, 0.1);  ///< box the centres are placed in [m]; every edge > 0
  std::size_t count = 100;          ///< quanta (≥ 2: zero total momentum needs two)
  double min_distance = 0;          ///< no two centres closer [m] (twice the contact radius)
  double quanta_mass = 1e-3;        ///< [kg]
  double kT = 1e-3;                 ///< k_B T [J]: the kinetic energy is exactly 3/2 count kT
  Speeds speeds = Speeds::maxwell;
  std::uint64_t seed = 1;           ///< same seed, same gas (positions as a random PointPacking)
};

/// Adds the gas to `world` as body `body`: positions as a random packing of the box (packing.hpp),
/// velocities with zero total momentum and kinetic energy exactly 3/2 count kT. Deterministic for
/// a seed (SplitMix64, +, ×, sqrt and, for Maxwell–Boltzmann, log). Throws std::invalid_argument
/// on bad parameters or when the box cannot hold the quanta min_distance apart.
std::vector<Index> add_gas(World& world, const Gas& spec, Index body = 0);

/// Kinetic temperature k_B T = (2/3) mean ½ m |v|² of the quanta `ids` [J]: the T of p V = N k_B T
/// for an ideal gas in a box at rest (the velocities are measured in the walls' frame).
double kinetic_temperature(const Model& model, const State& state, std::span<const Index> ids);

}  // namespace qbond
