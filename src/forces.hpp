#pragma once
// Bond-centric force passes shared by the explicit integrators and by analysis: each
// bond's force is computed once and applied to both ends (Newton's third law, exactly).
#include <vector>

#include "bond_partition.hpp"
#include "qbond/world.hpp"

namespace qbond {

// Force of every bond on its first quanta bond_i (the force on bond_j is its exact negative), law
// plus damping, at positions x and velocities v; 0 for broken bonds.
void bond_forces(const Model& model, const State& state, const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                 int threads, std::vector<Vec3>& force);

// f_i += Σ over i's alive bonds of ±(the bond's force on its first end) at x and v, in one pass
// over the bonds (bond_partition.hpp): each force computed once and added to both ends, each
// quanta's sum in bond order for any thread count.
void add_bond_forces(const Model& model, const State& state, const BondPartition& part, const std::vector<Vec3>& x,
                     const std::vector<Vec3>& v, std::vector<Vec3>& f);

// a = (f_bonds(x, v) + f_ext) / m for free quanta, 0 for kinematic ones.
void accelerations(const Model& model, const State& state, const BondPartition& part, const std::vector<Vec3>& x,
                   const std::vector<Vec3>& v, const std::vector<Vec3>& f_ext, int threads, std::vector<Vec3>& a);

}  // namespace qbond
