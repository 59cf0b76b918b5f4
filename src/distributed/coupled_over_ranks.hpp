#pragma once
// The coupled implicit step (backward Euler, backward_euler.hpp) of a run over ranks: each rank
// builds the system's rows of the free quanta it owns from its piece (local_world.hpp: an owned
// quanta's bonds are all in its piece), and the ranks solve (M + h C + h² K) Δv = b together with
// PETSc's CG, to qbond's CG stopping rule ‖b − A Δv‖ ≤ tolerance ‖b‖. Preconditioned by A's 3 × 3
// diagonal blocks (preconditioner block_jacobi), CG multiplies by A without forming it: qbond's
// own bond pass over the piece, the ghosts' rows of the vector brought from their owners. hypre's
// algebraic multigrid (BoomerAMG: multigrid, automatic) needs the matrix, which is then assembled
// into PETSc's format every step.
// Built with MPI and PETSc (QBOND_DISTRIBUTED_IMPLICIT).
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "integrators/advance.hpp"
#include "solvers/coloring.hpp"

namespace qbond {
struct ImplicitSystem;
}

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
  std::vector<Index> lone;  // the owned quanta that are a free component alone (no bonds)
};

// Rank `rank`'s layout (of `ranks`) given every quanta's owner, its piece's quanta (`global`: each
// local quanta's whole index; `owned`: the local indices it owns) and the whole world's free
// components.
SolveLayout solve_layout(const World& whole, std::span<const int> owner, int rank, int ranks,
                         std::span<const Index> global, std::span<const Index> owned,
                         const FreeComponents& components);

// restore_component_momentum over the whole world's free components on the owned rows of dv: each
// rank's sums over its owned members, added in rank order (the same shift on every rank), the
// components with a member `skip` flags on any rank left alone (collective).
void restore_momentum_over_ranks(const SolveLayout& layout, const Model& model, const std::vector<Vec3>& f_ext,
                                 double h, std::vector<Vec3>& dv, const std::vector<std::uint8_t>& skip = {});

// The coupled implicit integrator of one rank's piece, every rank taking each step together (its
// projection is collective). `config`: coupled_implicit with the cg solver. `whole_h`: while a
// step is taken in halves, its whole length, which sets the obstacle contacts' springs as alone
// (0: the step's own); it must outlive the integrator.
std::unique_ptr<StepIntegrator> make_coupled_over_ranks(const IntegratorConfig& config, SolveLayout layout,
                                                        const double& whole_h);

// A y for this rank's rows (3 per owned free quanta, in layout.owned_free's order) by both of the
// solve's operators, to check one against the other: `matrix_free` by the block-Jacobi solve's
// (qbond's bond pass over the piece: model, state.bonds, adj and sys, the system begin_implicit_step
// built on it), `assembled` by PETSc's matrix, which the multigrid solve takes. y holds this
// rank's rows too. Collective.
void apply_both_operators(const SolveLayout& layout, const Model& model, const State& state, const Adjacency& adj,
                          const ImplicitSystem& sys, const IntegratorConfig& config, const std::vector<double>& y,
                          std::vector<double>& matrix_free, std::vector<double>& assembled);

// CG over the ranks, as coupled_implicit's, on a system a piece's integrator builds itself (the
// Newton integrators' (M + Σ B_b) δ = −R each iteration).
class RanksSolve {
 public:
  virtual ~RanksSolve() = default;
  // The owned free quanta's rows of y solving sys (built on the piece: model, bonds, adj) from
  // zero, to ‖b − A y‖ ≤ tolerance ‖b‖; stats gets the iterations (collective).
  virtual void solve(const Model& model, const Bonds& bonds, const Adjacency& adj, const ImplicitSystem& sys,
                     double tolerance, std::vector<Vec3>& y, SolveStats& stats) = 0;
};

// The solve over the rows `layout` gives this rank (which must outlive it), for the piece's state
// and adjacency (the pattern holds while they do).
std::unique_ptr<RanksSolve> make_ranks_solve(const SolveLayout& layout, const State& state, const Adjacency& adj,
                                             const IntegratorConfig& config);

// Ends PETSc when a run over ranks started it (before MPI ends); nothing otherwise.
void end_petsc();

}  // namespace qbond::distributed
