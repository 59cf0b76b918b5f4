// The PETSc anchors of `qbond bench --solve` (bench/petsc_solve.hpp): PETSc's CG with GAMG and with
// hypre's BoomerAMG reach the solution of the implicit step's system that sparse LDLᵀ and qbond's
// CG reach, to the bound their residuals give.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>

#include "integrators/backward_euler.hpp"
#include "petsc_solve.hpp"
#include "qbond/builders/samples.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

constexpr double kH = 1.0 / 60, kTol = 1e-8;

struct System {
  Eigen::SparseMatrix<double> A;
  Eigen::VectorXd b, x_cg;  // x_cg: qbond's block-Jacobi CG's solution in A's numbering
  std::vector<double> coordinates;
  double cg_residual = 0;  // its true relative residual
};

// The backward-Euler system of one step at h = 1/60 s of `w` under gravity, assembled over the
// free unknowns, with qbond's CG's solution to kTol.
System implicit_system(const World& w) {
  const Model& m = w.model;
  Adjacency adj;
  build_adjacency(m, w.state, adj);
  std::vector<Vec3> f(w.num_quanta());
  for (std::size_t i = 0; i < f.size(); ++i) f[i] = m.mass[i] * m.gravity;
  ImplicitSystem sys;
  Projection kin;
  begin_implicit_step(m, w.state, adj, f, {.h = kH}, /*edges=*/false, 1, kin, sys);
  System s;
  std::vector<Eigen::Index> dof;
  std::vector<Eigen::Triplet<double>> triplets;
  assemble_system(m, w.state, sys, dof, triplets, s.A, s.b);
  s.coordinates.resize(static_cast<std::size_t>(s.A.rows()));
  s.x_cg.resize(s.A.rows());
  std::vector<Vec3> y(w.num_quanta(), Vec3::Zero());
  SolveStats stats;
  conjugate_gradient(m, w.state.bonds, sys, kTol, 100000, 1, y, /*y_zero=*/true, stats);
  for (std::size_t i = 0; i < dof.size(); ++i)
    if (dof[i] >= 0)
      for (int d = 0; d < 3; ++d) {
        s.coordinates[static_cast<std::size_t>(dof[i] + d)] = w.state.x[i][d];
        s.x_cg[dof[i] + d] = y[i][d];
      }
  s.cg_residual = (s.b - s.A * s.x_cg).norm() / s.b.norm();
  return s;
}

// For A symmetric positive definite, ‖x − x*‖ ≤ ‖b − A x‖ / λ_min(A): each solution's distance
// from the exact one is bounded by its residual, and two solutions' distance by the sum.
void expect_agreement(const System& s) {
  const Eigen::MatrixXd dense(s.A);
  const double lambda_min = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(dense).eigenvalues().minCoeff();
  ASSERT_GT(lambda_min, 0);
  const Eigen::VectorXd x_ldlt = Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>(s.A).solve(s.b);
  const double r_ldlt = (s.b - s.A * x_ldlt).norm();
  const double bn = s.b.norm();
  ASSERT_LE(s.cg_residual, kTol);
  for (const auto pc : {bench::PetscPreconditioner::gamg, bench::PetscPreconditioner::boomeramg}) {
    SCOPED_TRACE(pc == bench::PetscPreconditioner::gamg ? "GAMG" : "BoomerAMG");
    const bench::PetscSolveResult r = bench::petsc_solve(s.A, s.b, s.coordinates, pc, kTol, 1000);
    EXPECT_TRUE(r.converged);
    EXPECT_GT(r.iterations, 0);
    EXPECT_GT(r.setup_seconds, 0);
    // PETSc stops on its recursive residual; the true one may differ by rounding, not by more
    // than a factor.
    EXPECT_LE(r.true_residual, 2 * kTol);
    const double r_petsc = r.true_residual * bn;
    // Against the direct solution (1e-9 relative slack for the bound's own rounding).
    EXPECT_LE((r.x - x_ldlt).norm(), (r_petsc + r_ldlt) / lambda_min * (1 + 1e-9));
    // Against qbond's CG.
    EXPECT_LE((r.x - s.x_cg).norm(), (r_petsc + s.cg_residual * bn) / lambda_min * (1 + 1e-9));
    // And the agreement is not vacuous: the solution is far larger than the bound.
    EXPECT_GT(x_ldlt.norm(), 1e3 * (r_petsc + r_ldlt) / lambda_min);
  }
}

TEST(PetscAnchors, AgreeWithLdltAndCgOnTheCanonicalLattice) {
  expect_agreement(implicit_system(canonical_lattice(4).world));
}

TEST(PetscAnchors, AgreeOnAFreeBody) {
  // No anchor: A is M plus the (singular, rigid-body null space) h C + h² K.
  expect_agreement(implicit_system(test::lattice(5, 4, 3, 1000, 1e-3, 0.01, false, Vec3(0, 0, -9.81))));
}

}  // namespace
}  // namespace qbond
