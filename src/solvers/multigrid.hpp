#pragma once
// Smoothed-aggregation multigrid (Vaněk, Mandel, Brezina 1996) for symmetric positive definite
// systems of points with three unknowns each (the implicit step's M + h C + h² K), and conjugate
// gradient preconditioned by one of its V-cycles.
//
// Each level: its operator A_l (3×3 blocks on the finest, 6×6 on the coarser ones: six rigid
// modes an aggregate), the prolongator from the next level P = (I − ω D⁻¹ A_l) P0 (P0 the rigid
// modes orthonormalised on each aggregate: aggregation.hpp; ω = 4 / (3 λ_max(D⁻¹ A_l)); D A_l's
// diagonal blocks), and the Galerkin operator A_{l+1} = Pᵀ A_l P. The smoother is a Chebyshev
// polynomial in D⁻¹ A_l on [1.1 λ_max / 5, 1.1 λ_max] (λ_max by power iteration), the same before and
// after the coarse correction, so that the V-cycle is a symmetric operator, positive definite as
// long as the smoother converges; the coarsest level is solved by sparse LDLᵀ. The cycle reads its
// matrices in single precision (PackedMatrix): still a fixed symmetric operator. Every pass runs
// each block row on one thread in a fixed order, and the dot products sum fixed chunks in order:
// the same bits for any thread count.
#include <Eigen/SparseCholesky>
#include <functional>
#include <vector>

#include "qbond/integrators/integrators.hpp"
#include "solvers/aggregation.hpp"
#include "solvers/block_matrix.hpp"

namespace qbond {

class Multigrid {
 public:
  /// y = A x for the fine level's unknowns.
  using Operator = std::function<void(const double* x, double* y)>;

  /// The fine operator the cycle, CG and the set-up's estimate of λ_max apply (a matrix-free
  /// product: the fine level's assembled matrix is then only read by build and update, to form
  /// the prolongator and the coarse operator); without one they read the fine matrix packed.
  void set_fine_operator(Operator op) { fine_op_ = std::move(op); }

  /// Builds the hierarchy for A (3×3 blocks, SPD) whose block row i holds the unknowns of the
  /// point at x[i]: aggregates, prolongators and coarse operators. A is copied: the hierarchy stays
  /// a fixed preconditioner until the next build or update.
  void build(const BlockMatrix& A, const std::vector<Vec3>& x, int threads);
  /// The same aggregates and prolongators with A's values (its block rows the built ones; its
  /// pattern may differ, after bonds break or form): operators, smoothers and coarse solve anew.
  void update(const BlockMatrix& A, int threads);
  /// The fine level's smoother takes `block` (3×3, row-major) as block row `row`'s diagonal block
  /// (the rest of the hierarchy kept): where the system's diagonal moved far since the build or
  /// update (contacts' springs come and go), smoothing with the old block hardly acts there.
  void set_fine_diagonal(std::size_t row, const double* block);
  bool built() const { return !levels_.empty(); }
  std::size_t levels() const { return levels_.size(); }
  /// Unknowns on each level.
  std::vector<std::size_t> unknowns() const;

  /// z = one V-cycle applied to r (the fine level's unknowns).
  void apply(const double* r, double* z, int threads);

  /// Conjugate gradient on A y = b (A with the built block rows, not necessarily the built
  /// values), preconditioned by apply, from y (scaled by yᵀb / yᵀA y first, as the
  /// block-Jacobi CG does; y_zero: y is 0) until ‖b − A y‖/max(‖b‖, scale) ≤ tolerance (CG's
  /// recurrence) or `cap` iterations.
  void solve(const Operator& A, const std::vector<double>& b, double tolerance, int cap, int threads,
             std::vector<double>& y, bool y_zero, SolveStats& stats, double scale = 0);

  /// Chebyshev degree of the smoother before and after each coarse correction.
  int smoothing_degree = 2;
  /// Coarsening stops at this many unknowns or fewer.
  std::size_t coarsest = 600;
  /// The finest level's aggregates take the points within this many bonds of their root, 1 or 2
  /// (the coarser levels' within one). Two: the fine level is applied matrix-free and cheaply, the
  /// prolongator and the next level's operator are not; on the canonical lattice two-bond
  /// aggregates halve the coarse unknowns and cut the coarse operator's blocks threefold and the
  /// prolongator's by a quarter, for about the same iterations.
  int fine_aggregate_radius = 2;

 private:
  struct Level {
    BlockMatrix A;
    std::vector<double> Dinv;        // A's diagonal blocks inverted, bs × bs each
    double lambda = 1;               // λ_max(D⁻¹A), estimated
    BlockMatrix P, R, AP;            // from the next level (none on the coarsest), R = Pᵀ, AP scratch
    PackedMatrix<float> Af, Pf, Rf;  // A (not the fine level's, with a fine operator), P, R as the cycle reads them
    std::vector<double> x, b, r, d, t;
  };
  void apply_swapping(std::vector<double>& r, std::vector<double>& z, int threads);  // apply, r and z sized
  void smoother(Level& L, bool symmetric, int threads);  // symmetric: A's blocks each are
  void galerkin(std::size_t l, int threads);
  void factor_coarsest();
  void pack_levels(int threads);  // P and R as the cycle reads them
  void release_fine();            // frees the fine level's double copy once packed
  void chebyshev(Level& L, bool zero_start, int threads);
  void cycle(std::size_t l, int threads);
  void level_multiply(std::size_t l, const double* x, double* y, int threads);
  void level_residual(std::size_t l, const double* b, const double* x, double* r, int threads);

  std::vector<Level> levels_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> coarse_;
  std::vector<double> r_, z_, p_, q_;  // CG's vectors
  Operator fine_op_;
};

}  // namespace qbond
