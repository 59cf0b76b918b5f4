#pragma once
/// Static equilibrium: the deformed shape a structure settles to under its constant loads and
/// gravity, without running the dynamics to rest. It serves quick stress estimates, material
/// calibration (materials.hpp) and the exact reference of the cantilever experiment.
#include <Eigen/SparseCore>
#include <vector>

#include "qbond/model/world.hpp"

namespace qbond {

/// The stiffness matrix of the alive bonds at the state's positions over the free quanta:
/// K = Σ_b blocks of ∂f/∂x (tangent stiffness, including the geometric term T/r (I − u uᵀ)),
/// 3 rows per free quanta in id order; `dof[i]` is quanta i's first row, or -1 if kinematic.
Eigen::SparseMatrix<double> stiffness_matrix(const Model& model, const State& state, std::vector<Eigen::Index>& dof);

/// How solve_static ended.
struct StaticResult {
  int iterations = 0;
  double residual = 0;  ///< ‖net force on free quanta‖ at the end over the larger of ‖external
                        ///< force‖ and the start's ‖net force‖
  bool converged = false;
};

/// Moves the free quanta of `world` to the equilibrium of bond forces with gravity and loads
/// (kinematic quanta stay where they are), by Newton's method on f(x) = 0 with the sparse
/// stiffness matrix (Eigen's LDLᵀ up to 60 000 unknowns, incomplete-Cholesky-preconditioned CG
/// beyond) and a backtracking line search; velocities are set to 0.
/// Stops at a relative residual below `tolerance`. Directions that resist nothing and carry no
/// force (a straight chain sideways) stay put; when the loads push along such a direction (a
/// free body under an unbalanced load, a mechanism) there is no equilibrium and the result says
/// converged = false, with the state at the smallest residual found.
StaticResult solve_static(World& world, double tolerance = 1e-10, int max_iterations = 50);

}  // namespace qbond
