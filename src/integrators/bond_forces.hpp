#pragma once
// Bond-centric force passes shared by the explicit integrators and by analysis: each
// bond's force is computed once and applied to both ends (Newton's third law, exactly).
#include <vector>

#include "integrators/bond_partition.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

// Force of every bond on its first quanta bond_i (the force on bond_j is its exact negative), law
// plus damping, at positions x and velocities v; 0 for broken bonds.
void bond_forces(const Model& model, const State& state, const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                 int threads, std::vector<Vec3>& force);

// What accelerations keeps from call to call (so that a step allocates nothing): its per-quanta
// arrays.
struct ForceArrays {
  LineVector<double> data;
};

// The force pass's per-quanta arrays as structure of arrays: the force sums f and the positions
// and velocities, from which affine runs load contiguous vectors.
struct ForceRows {
  double* f[3];
  double* x[3];
  double* v[3];
};

// Rows for n quanta in work's storage (valid until work is next resized).
ForceRows force_rows(ForceArrays& work, std::size_t n);

// rows.f += the alive bonds' forces at rows.x, rows.v, each computed once and added to both ends
// in one pass over the bonds (bond_partition.hpp), each quanta's terms in bond order for any
// thread count (the partition's); affine runs of linear bonds by vector loops (affine_run_terms.hpp).
// For callers that fill the rows themselves; bond_force_sums wraps it.
void add_bond_forces(const Model& model, const State& state, const BondPartition& part, const ForceRows& rows);

// f = f_ext + Σ over each quanta's alive bonds of ±(the bond's force on its first end) at x and
// v, in one pass over the bonds (bond_partition.hpp): each force computed once and added to both
// ends, each quanta's sum in bond order for any thread count; affine runs of linear bonds by
// vector loops (affine_run_terms.hpp). An empty f_ext stands for no external force.
void bond_force_sums(const Model& model, const State& state, const BondPartition& part, const std::vector<Vec3>& x,
                     const std::vector<Vec3>& v, const std::vector<Vec3>& f_ext, int threads, ForceArrays& work,
                     std::vector<Vec3>& f);
// work's rows (force_rows) holding x, v and the bond forces alone (no external force) at them, as
// bond_force_sums sums them.
ForceRows bond_force_rows(const Model& model, const State& state, const BondPartition& part, const Vec3* x,
                          const Vec3* v, int threads, ForceArrays& work);

// a = (f_ext + the bond forces at x, v) / m for free quanta, 0 for kinematic ones (bond_force_sums).
void accelerations(const Model& model, const State& state, const BondPartition& part, const std::vector<Vec3>& x,
                   const std::vector<Vec3>& v, const std::vector<Vec3>& f_ext, int threads, ForceArrays& work,
                   std::vector<Vec3>& a);

}  // namespace qbond
