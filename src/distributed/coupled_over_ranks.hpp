#pragma once
// The coupled implicit step (backward Euler, backward_euler.hpp) of a run over ranks: each rank
// builds the system's rows of the free quanta it owns from its piece (local_world.hpp: an owned
// quanta's bonds are all in its piece), and the ranks solve (M + h C + h² K) Δv = b together with
// PETSc's CG preconditioned by A's 3 × 3 diagonal blocks (preconditioner block_jacobi) or by
// hypre's algebraic multigrid (BoomerAMG: multigrid, automatic), to qbond's CG stopping rule
// ‖b − A Δv‖ ≤ tolerance ‖b‖.
// Built with MPI and PETSc (QBOND_DISTRIBUTED_IMPLICIT).
#include <cstdint>
#include <memory>
#include <vector>

#include "integrators/advance.hpp"

namespace qbond::distributed {

// Where a rank's piece sits in the whole system: the global numbering of the free quanta (each
// rank's owned free quanta in whole-world order, rank after rank) and the whole world's free
// components, for the momentum restoration every rank takes part in.
struct SolveLayout {
  std::vector<std::int64_t> row;  // per local quanta: its block row in the whole system, -1 if kinematic
  std::vector<Index> owned_free;  // local indices of the owned free quanta: this rank's rows, in order
  std::int64_t first_row = 0;     // the block row of owned_free[0]
  std::int64_t rows = 0;          // block rows of the whole system (free quanta of the whole world)
  // The whole world's free components (no bond to a kinematic quanta), each with its owned
  // members (local indices, in the component's order) and its whole mass.
  std::vector<Index> component_offset;  // (components + 1)
  std::vector<Index> component_owned;
  std::vector<double> component_mass;
};

// The coupled implicit integrator of one rank's piece, every rank taking each step together (its
// projection is collective). `config`: coupled_implicit with the cg solver.
std::unique_ptr<StepIntegrator> make_coupled_over_ranks(const IntegratorConfig& config, SolveLayout layout);

// Ends PETSc when a run over ranks started it (before MPI ends); nothing otherwise.
void end_petsc();

}  // namespace qbond::distributed
