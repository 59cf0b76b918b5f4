#pragma once
// Bond-centric force and linearisation passes shared by every integrator and by analysis.
#include <vector>

#include "qbond/world.hpp"

namespace qbond {

// f += Σ over alive bonds of the bond force (law + damping) at positions x, velocities v.
// Each bond is visited once and its force applied to both ends (Newton's third law, exactly).
void add_bond_forces(const Model& model, const State& state, const std::vector<Vec3>& x,
                     const std::vector<Vec3>& v, std::vector<Vec3>& f);

// a = (f_bonds(x, v) + f_ext) / m for free quanta, 0 for kinematic ones.
void accelerations(const Model& model, const State& state, const std::vector<Vec3>& x,
                   const std::vector<Vec3>& v, const std::vector<Vec3>& f_ext,
                   std::vector<Vec3>& a);

// Per-bond linearisation at the state's positions: the force on i (f_i = -f_j), the stiffness
// block K_b (clamped positive semi-definite, see laws.hpp) and the damping block C_b.
// Broken or zero-length bonds get zero blocks.
struct BondLinearisation {
  std::vector<Vec3> force;  // force on bond_i [N] (nb)
  std::vector<Mat3> K;      // [N/m] (nb)
  std::vector<Mat3> C;      // [N·s/m] (nb)
};
void linearise_bonds(const Model& model, const State& state, BondLinearisation& out);

}  // namespace qbond
