#include "petsc_solve.hpp"

#include <petscksp.h>

#include <chrono>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace qbond::bench {
namespace {

void check(PetscErrorCode code, const char* call) {
  if (code != 0)
    throw std::runtime_error(std::string("PETSc: ") + call + " failed (error " + std::to_string(code) + ")");
}

void start_petsc() {
  static const bool started = [] {
    PetscBool up = PETSC_FALSE;
    check(PetscInitialized(&up), "PetscInitialized");
    if (!up) {
      check(PetscInitializeNoArguments(), "PetscInitializeNoArguments");
      std::atexit([] { (void)PetscFinalize(); });
    }
    return true;
  }();
  (void)started;
}

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

PetscSolveResult petsc_solve(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& b,
                             const std::vector<double>& coordinates, PetscPreconditioner pc_kind,
                             double tolerance, int cap) {
  start_petsc();
  const auto n = static_cast<PetscInt>(A.rows());
  if (A.cols() != A.rows() || b.size() != A.rows() || n % 3 != 0 ||
      coordinates.size() != static_cast<std::size_t>(n))
    throw std::invalid_argument(
        "petsc_solve: A must be square with 3 unknowns a quanta, b and the coordinates as long");
  PetscSolveResult out;
  auto t0 = std::chrono::steady_clock::now();
  // PETSc takes compressed rows; A's row-major copy in PETSc's index type.
  Eigen::SparseMatrix<double, Eigen::RowMajor, PetscInt> rows = A;
  rows.makeCompressed();
  Mat M;
  Vec x, rhs, coords;
  KSP ksp;
  MatNullSpace rigid;
  check(MatCreate(PETSC_COMM_SELF, &M), "MatCreate");
  check(MatSetSizes(M, n, n, n, n), "MatSetSizes");
  check(MatSetType(M, MATSEQAIJ), "MatSetType");
  check(MatSetBlockSize(M, 3), "MatSetBlockSize");
  check(MatSeqAIJSetPreallocationCSR(M, rows.outerIndexPtr(), rows.innerIndexPtr(), rows.valuePtr()),
        "MatSeqAIJSetPreallocationCSR");
  check(MatSetOption(M, MAT_SPD, PETSC_TRUE), "MatSetOption(MAT_SPD)");
  check(VecCreateSeq(PETSC_COMM_SELF, n, &rhs), "VecCreateSeq");
  check(VecDuplicate(rhs, &x), "VecDuplicate");
  check(VecCreateSeq(PETSC_COMM_SELF, n, &coords), "VecCreateSeq");
  check(VecSetBlockSize(coords, 3), "VecSetBlockSize");
  {
    PetscScalar *pb = nullptr, *pc = nullptr;
    check(VecGetArray(rhs, &pb), "VecGetArray");
    check(VecGetArray(coords, &pc), "VecGetArray");
    for (PetscInt k = 0; k < n; ++k) {
      pb[k] = b[k];
      pc[k] = coordinates[static_cast<std::size_t>(k)];
    }
    check(VecRestoreArray(rhs, &pb), "VecRestoreArray");
    check(VecRestoreArray(coords, &pc), "VecRestoreArray");
  }
  if (pc_kind == PetscPreconditioner::gamg) {
    check(MatNullSpaceCreateRigidBody(coords, &rigid), "MatNullSpaceCreateRigidBody");
    check(MatSetNearNullSpace(M, rigid), "MatSetNearNullSpace");
    check(MatNullSpaceDestroy(&rigid), "MatNullSpaceDestroy");
  }
  out.matrix_seconds = since(t0);

  t0 = std::chrono::steady_clock::now();
  check(KSPCreate(PETSC_COMM_SELF, &ksp), "KSPCreate");
  check(KSPSetOperators(ksp, M, M), "KSPSetOperators");
  check(KSPSetType(ksp, KSPCG), "KSPSetType(KSPCG)");
  check(KSPSetNormType(ksp, KSP_NORM_UNPRECONDITIONED), "KSPSetNormType");
  check(KSPSetTolerances(ksp, tolerance, 0.0, PETSC_DEFAULT, cap), "KSPSetTolerances");
  PC pc;
  check(KSPGetPC(ksp, &pc), "KSPGetPC");
  if (pc_kind == PetscPreconditioner::gamg) {
    check(PCSetType(pc, PCGAMG), "PCSetType(PCGAMG)");
  } else {
    check(PCSetType(pc, PCHYPRE), "PCSetType(PCHYPRE)");
    check(PCHYPRESetType(pc, "boomeramg"), "PCHYPRESetType(boomeramg)");
  }
  check(KSPSetUp(ksp), "KSPSetUp");
  out.setup_seconds = since(t0);
  if (pc_kind == PetscPreconditioner::gamg) {
    PetscInt levels = 0;
    check(PCMGGetLevels(pc, &levels), "PCMGGetLevels");
    out.levels = static_cast<int>(levels);
  }

  t0 = std::chrono::steady_clock::now();
  check(KSPSolve(ksp, rhs, x), "KSPSolve");
  out.solve_seconds = since(t0);
  PetscInt its = 0;
  KSPConvergedReason reason;
  check(KSPGetIterationNumber(ksp, &its), "KSPGetIterationNumber");
  check(KSPGetConvergedReason(ksp, &reason), "KSPGetConvergedReason");
  out.iterations = static_cast<int>(its);
  out.converged = reason > 0;
  out.x.resize(n);
  {
    const PetscScalar* px = nullptr;
    check(VecGetArrayRead(x, &px), "VecGetArrayRead");
    for (PetscInt k = 0; k < n; ++k) out.x[k] = px[k];
    check(VecRestoreArrayRead(x, &px), "VecRestoreArrayRead");
  }
  check(KSPDestroy(&ksp), "KSPDestroy");
  check(VecDestroy(&x), "VecDestroy");
  check(VecDestroy(&rhs), "VecDestroy");
  check(VecDestroy(&coords), "VecDestroy");
  check(MatDestroy(&M), "MatDestroy");
  out.true_residual = (b - A * out.x).norm() / b.norm();
  return out;
}

}  // namespace qbond::bench
