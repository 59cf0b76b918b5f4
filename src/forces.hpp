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

// What accelerations keeps from call to call (so that a step allocates nothing): its per-quanta
// arrays.
struct ForceArrays {
  std::vector<double> data;
};

// f = f_ext + Σ over each quanta's alive bonds of ±(the bond's force on its first end) at x and
// v, in one pass over the bonds (bond_partition.hpp): each force computed once and added to both
// ends, each quanta's sum in bond order for any thread count; affine runs of linear bonds by
// vector loops (affine_rows.hpp). An empty f_ext stands for no external force.
void bond_force_sums(const Model& model, const State& state, const BondPartition& part, const std::vector<Vec3>& x,
                     const std::vector<Vec3>& v, const std::vector<Vec3>& f_ext, int threads, ForceArrays& work,
                     std::vector<Vec3>& f);
// The bond forces alone (no external force) for arrays of the model's quanta count.
void bond_force_sums(const Model& model, const State& state, const BondPartition& part, const Vec3* x, const Vec3* v,
                     int threads, ForceArrays& work, Vec3* f);

// a = (f_ext + the bond forces at x, v) / m for free quanta, 0 for kinematic ones (bond_force_sums).
void accelerations(const Model& model, const State& state, const BondPartition& part, const std::vector<Vec3>& x,
                   const std::vector<Vec3>& v, const std::vector<Vec3>& f_ext, int threads, ForceArrays& work,
                   std::vector<Vec3>& a);

}  // namespace qbond
