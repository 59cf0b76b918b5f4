#pragma once
// PETSc's algebraic multigrid on qbond's assembled implicit system (M + hC + h²K) y = b, the anchors
// `qbond bench --solve` sets beside qbond's own solvers: CG preconditioned by GAMG (smoothed
// aggregation, given the rigid-body modes of the free quanta's positions as near-null space) and
// by hypre's BoomerAMG, both with PETSc's default options otherwise.
#include <Eigen/SparseCore>
#include <vector>

namespace qbond::bench {

enum class PetscPreconditioner { gamg, boomeramg };

/// One solve's result and costs; the residual is recomputed from A and b, not PETSc's.
struct PetscSolveResult {
  Eigen::VectorXd x;
  double matrix_seconds = 0;  ///< copying A, b and the coordinates into PETSc's objects
  double setup_seconds = 0;   ///< KSPSetUp: the preconditioner's hierarchy
  double solve_seconds = 0;   ///< KSPSolve
  int iterations = 0;
  int levels = 0;            ///< the hierarchy's levels (GAMG; 0 when PETSc does not say)
  double true_residual = 0;  ///< ‖b − A x‖ / ‖b‖
  bool converged = false;    ///< PETSc's converged reason is positive
};

/// Solves A x = b (A symmetric positive definite over the free unknowns, 3 a quanta, blocks of 3;
/// `coordinates`: the free quanta's positions, 3 a quanta in A's order) by PETSc's CG to
/// ‖b − A x‖ ≤ tolerance ‖b‖ (the unpreconditioned norm, qbond's CG's criterion) or `cap`
/// iterations, from zero. Starts PETSc (one MPI process) on first use and ends it at exit;
/// throws std::runtime_error naming the PETSc call that failed.
PetscSolveResult petsc_solve(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& b,
                             const std::vector<double>& coordinates, PetscPreconditioner pc, double tolerance,
                             int cap);

}  // namespace qbond::bench
