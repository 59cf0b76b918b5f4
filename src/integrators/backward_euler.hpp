#pragma once
// The linearised backward-Euler step shared by the hybrid and coupled integrators.
//
// Backward Euler, M Δv = h f(x + Δx, v + Δv) with Δx = h (v + Δv), linearised about the start of
// the step (f(x+Δx, v+Δv) ≈ f - K Δx - C Δv) gives, for the free quanta (Eq. 13 linearised):
//     (M + h C + h² K) Δv = h f - h K Δx₀ - h C Δv_k,
// where Δx₀ = h v for free quanta and the prescribed displacement for kinematic ones, and Δv_k is
// the prescribed velocity change of kinematic quanta (0 for free ones). Kinematic unknowns are
// eliminated, so A = M + h C + h² K only couples free quanta. Per bond b = (i, j):
//     A_ii += B_b,  A_jj += B_b,  A_ij = A_ji = -B_b,   B_b = h C_b + h² K_b.
// The paper's hybrid (`frozen`) keeps only the diagonal blocks and drops the neighbours' terms
// from the right-hand side: A_ii Δv_i = h f_i - h² (Σ_b K_b) v_i (Eq. 12).
#include <Eigen/Sparse>
#include <algorithm>
#include <vector>

#include "integrators/advance.hpp"
#include "integrators/bond_partition.hpp"
#include "integrators/prescribed.hpp"
#include "integrators/ranks_link.hpp"
#include "solvers/coloring.hpp"
#include "qbond/model/world.hpp"
#include "qbond/integrators/integrators.hpp"
#include "qbond/laws/laws.hpp"

namespace qbond {

// Every bond block of the step has the form a u uᵀ + b I (u the bond's unit vector): the clamped
// stiffness K_b = (T' − T/r) u uᵀ + (T/r) I, axial damping D u uᵀ, isotropic damping D I. The
// system keeps the two coefficients and u per bond (5 numbers for a 3×3 block), and a product
// costs a dot product and two scaled adds.
inline Vec3 block_times(const Vec3& u, double a, double b, const Vec3& y) { return a * u.dot(y) * u + b * y; }
inline Mat3 block_matrix(const Vec3& u, double a, double b) {
  Mat3 m = a * u * u.transpose();
  m.diagonal().array() += b;
  return m;
}

// One bond's linearisation at the start of the step: its unit vector u (bond_i to bond_j), its
// tension T and its force on bond_i f = T u + C_b (v_j − v_i) (law plus damping), and its stiffness
// and damping blocks, K_b = ka u uᵀ + kb I (clamped at 0 so that A stays positive definite:
// laws.hpp, stiffness_block) and C_b = ca u uᵀ + cb I. All 0 for a zero-length bond, which has no
// direction.
struct BondLinearisation {
  Vec3 u = Vec3::Zero(), f = Vec3::Zero();
  double T = 0, ka = 0, kb = 0, ca = 0, cb = 0;
};
[[gnu::always_inline]] inline BondLinearisation linearise_bond(const Model& model, const State& state, Index b) {
  BondLinearisation l;
  const Index i = state.bonds.i[b], j = state.bonds.j[b];
  const Vec3 d = state.x[j] - state.x[i];
  const double r = d.norm();
  if (!(r > 0)) return l;
  const double inv_r = 1.0 / r;  // one division per bond
  l.u = inv_r * d;
  const LawValue lv = state.bonds.law_at(model.shapes, b, r, state.bonds.rest[b]);
  l.T = lv.T;
  const Vec3 w = state.v[j] - state.v[i];
  const double D = state.bonds.damping[b];
  const bool axial = state.bonds.damping_model[b] == DampingModel::axial;
  l.f = axial ? Vec3((lv.T + D * w.dot(l.u)) * l.u) : Vec3(lv.T * l.u + D * w);
  const StiffnessCoefficients k = clamped_stiffness(lv.dT, lv.T * inv_r);
  l.ka = k.ka();
  l.kb = k.kb();
  (axial ? l.ca : l.cb) = D;
  return l;
}

// Every bond's B_b = Ba u uᵀ + Bb I, in bond order, as structure of arrays: CG's product reads an
// affine run's as contiguous vectors (conjugate_gradient.cpp), the direct solvers assemble from
// them. Valid for alive bonds with a free end; u is 0 for a zero-length bond.
struct BondBlocks {
  std::vector<double> ux, uy, uz, Ba, Bb;
  void resize(std::size_t nb) {
    for (std::vector<double>* a : {&ux, &uy, &uz, &Ba, &Bb}) a->resize(nb);
  }
  void set(std::size_t b, const Vec3& u, double a, double c) {
    ux[b] = u.x();
    uy[b] = u.y();
    uz[b] = u.z();
    Ba[b] = a;
    Bb[b] = c;
  }
  Vec3 u(std::size_t b) const { return {ux[b], uy[b], uz[b]}; }
};

// B_b as seen from one end of the bond, in adjacency order so that a quanta's row is one
// contiguous run: what the per-quanta solvers (Gauss–Seidel, Jacobi) read every sweep.
struct EdgeBlock {
  Vec3 u = Vec3::Zero();
  double Ba = 0, Bb = 0;  // 0 when the neighbour is kinematic (its unknown is eliminated)
};

// The six distinct entries of a u uᵀ + c I (xx, yy, zz, xy, xz, yz).
inline void block_entries(const Vec3& u, double a, double c, double (&B)[6]) {
  const Vec3 au = a * u;
  B[0] = au.x() * u.x() + c;
  B[1] = au.y() * u.y() + c;
  B[2] = au.z() * u.z() + c;
  B[3] = au.x() * u.y();
  B[4] = au.x() * u.z();
  B[5] = au.y() * u.z();
}

// A coupling of two quanta other than a bond (a contact between them in the step's solve): the
// block B = a u uᵀ + b I is in A_ii and A_jj (sys.diag) and −B in A_ij and A_ji.
struct PairCoupling {
  Index i = 0, j = 0;
  Vec3 u = Vec3::Zero();
  double a = 0, b = 0;
};

struct ImplicitSystem {
  BondBlocks bonds;
  std::vector<PairCoupling> couplings;  // besides the bonds' (contact_solve.hpp); empty without contact
  std::vector<EdgeBlock> edges;  // per adjacency entry of a free quanta (adj.offset[n]), when asked for
  std::vector<Mat3> diag;      // A_ii (n); identity for kinematic quanta
  std::vector<Mat3> diag_inv;  // A_ii⁻¹ (n)
  std::vector<Vec3> rhs;       // b (n); 0 for kinematic quanta
  double rhs_norm = 0;         // ‖b‖ over free quanta
  // h‖f_ext‖ over free quanta (begin_implicit_step; 0 where no build sets it): where the forces
  // balance, b → 0, and a residual relative to ‖b‖ alone would ask for ever more digits of that
  // balance; relative to max(‖b‖, h‖f_ext‖) a body at rest is solved as well as a falling one.
  double load_norm = 0;
  // The scale of the relative residual ‖b − A Δv‖ / residual_scale() at which the solves stop.
  double residual_scale() const { return std::max(rhs_norm, load_norm); }
  // The Newton integrators' exact Jacobian (exact Newton iterations): each bond's B_b as a full 3×3 block
  // (non-symmetric, indefinite), which then replaces `bonds`' a u uᵀ + b I in assemble_system;
  // empty otherwise.
  std::vector<Mat3> exact;  // (nb when used)
  // The bond-centric passes' partition (begin_implicit_step and assemble_blocks keep it current;
  // CG's product runs over it) and the per-quanta scratch of the build (backward_euler_build.cpp) and then
  // of CG (conjugate_gradient): one buffer, since their uses do not overlap.
  BondPartition part;
  LineVector<double> arrays;
  PrescribedAt prescribed;  // begin_implicit_step's
};

// Starts an implicit step: sizes `out` and fills its kinematic rows (project_kinematic), then
// builds A's blocks and b in one bond-centric pass (backward_euler_build.cpp: each bond linearised once,
// affine runs in vector loops; its block written in bond order and added to both ends' diagonal
// block and right-hand side, in bond order for any thread count) and a pass over the quanta
// (diagonal blocks and their inverses). With `edges`, also the edge blocks the per-quanta solvers
// read (gather_edges).
void begin_implicit_step(const Model& model, const State& state, const Adjacency& adj,
                         const std::vector<Vec3>& f_ext, const StepContext& ctx, bool edges, int threads,
                         Projection& out, ImplicitSystem& sys);

// A's blocks from per-bond B_b (sys.bonds, as the Newton integrators fill them): diag = m I + Σ B_b
// and its inverse for every free quanta (identity for kinematic ones), summed bond-centric in bond
// order (backward_euler_build.cpp: affine runs in vector loops; the same bits for any thread count), and
// with `edges` the edge blocks the sweeps read; updates sys.part. Leaves rhs alone.
void assemble_blocks(const Model& model, const Bonds& bonds, const Adjacency& adj, int threads, bool edges,
                     ImplicitSystem& sys);

// sys.edges from sys.bonds, each free quanta's in its adjacency order: its bond's block, 0
// towards a kinematic neighbour (whose unknown is eliminated).
void gather_edges(const Model& model, const Adjacency& adj, int threads, ImplicitSystem& sys);

// The paper's hybrid step (Eq. 12: neighbours held at their start positions and at rest), in one
// bond-centric pass (bond_partition.hpp) and one pass over the quanta. Eq. 12 reads
// A_ii Δv_i = h f_i − h² K_i v_i with A_ii = m I + h C_i + h² K_i (C_i, K_i: Σ C_b, Σ K_b over i's
// bonds) and f_i = f_ext,i + Σ_b (T_b u_b + C_b (v_j − v_i)); adding A_ii v_i to both sides cancels
// the K_i and C_i v_i terms: A_ii (v_i + Δv_i) = m v_i + h f_ext,i + h Σ_b (T_b u_b + C_b v_j).
// Each bond is linearised once, in vectorised runs (hybrid_frozen_kernel.cpp), and added to both ends' A_ii
// (kept as its six distinct entries) and that right-hand side; then, for free quanta,
// v_i + Δv_i = A_ii⁻¹ (…) goes straight into `out` (dx = h (v + Δv), Eq. 10), whose prescribed
// rows are project_kinematic's (written with their range's: PrescribedAt), or, when the step
// advances in place (`to` not null: advance.hpp), into the state the step applies, checked there
// (out's dx and dv then left empty).
struct FrozenStep {
  BondPartition part;
  LineVector<double> arrays;   // A_ii's six entries, b_i, x and v as structure of arrays (hybrid_frozen_kernel.cpp)
  Index wake = 512;            // the fewest rows started or solved at a time in the bond pass (tests: fewer)
  PrescribedAt prescribed;
  void project(const Model& model, const State& state, const Adjacency& adj, const std::vector<Vec3>& f_ext,
               const StepContext& ctx, int threads, Projection& out, Advanced* to);
};

// A's off-diagonal part times y for free quanta i: Σ over i's bonds to free quanta of B_b y_j.
inline Vec3 neighbours_times(const Adjacency& adj, const ImplicitSystem& sys, Index i, const std::vector<Vec3>& y) {
  Vec3 s = Vec3::Zero();
  for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
    const EdgeBlock& eb = sys.edges[e];
    s += block_times(eb.u, eb.Ba, eb.Bb, y[adj.other[e]]);
  }
  return s;
}

// out = A y over free quanta (y's kinematic rows are ignored; out's kinematic rows are 0) as CG
// computes it: diag, then bond-centric over sys.part (sys.bonds in bond order), −B_b y_j into row
// i and −B_b y_i into row j (y's kinematic rows taken as 0, so a bond to a kinematic quanta adds
// nothing to its free end's row; conjugate_gradient.cpp). Allocates its scratch: for checks, CG
// keeps its own.
void apply_system(const Model& model, const Bonds& bonds, const ImplicitSystem& sys,
                  const std::vector<Vec3>& y, int threads, std::vector<Vec3>& out);

// A and b over the free unknowns as a sparse matrix and a vector, for the direct solvers (and the
// benchmarks' Eigen solvers): dof[i] = 3 × free quanta i's number, -1 for kinematic quanta.
// Returns the number of free quanta; `triplets` is scratch. When sys.exact is filled, A is
// M + Σ_b of those full blocks (A_ii += B_b, A_jj += B_b, A_ij = A_ji = −B_b, summed in bond
// order) instead of sys.diag and the a u uᵀ + b I blocks.
Eigen::Index assemble_system(const Model& model, const State& state, const ImplicitSystem& sys,
                             std::vector<Eigen::Index>& dof, std::vector<Eigen::Triplet<double>>& triplets,
                             Eigen::SparseMatrix<double>& A, Eigen::VectorXd& b);

// The linear solvers of A y = b (b = sys.rhs), shared by the coupled integrator (one solve per step)
// and the Newton integrators (one per Newton iteration); each owns its scratch.

// The sparsity pattern (a compressed matrix's outer and inner indices) that a factorisation's
// symbolic analysis was done for. The analysis — the fill-reducing ordering and the elimination
// tree — depends on the pattern alone, which stays the same from one Newton iteration or step to
// the next until a bond breaks or forms, so it is redone only then; a factorisation after the kept
// analysis gives the bits a fresh one would.
struct SparsityPattern {
  std::vector<int> outer, inner;
  // Whether A (compressed) has this pattern; if not, the pattern becomes A's and the caller
  // analyses A.
  bool matches(const Eigen::SparseMatrix<double>& A);
};

// Sparse LDLᵀ or dense Gaussian elimination with partial pivoting on the assembled system; y is
// overwritten (kinematic rows 0). solve_lu: sparse LU (the Newton integrators' non-symmetric
// exact Jacobian, sys.exact); false if the factorisation failed (a singular matrix; y is then 0).
struct DirectSolver {
  std::vector<Eigen::Index> dof;
  std::vector<Eigen::Triplet<double>> triplets;
  Eigen::SparseMatrix<double> A;
  Eigen::VectorXd b;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> lu;
  SparsityPattern ldlt_pattern, lu_pattern;  // what ldlt and lu were analysed for
  void solve(CoupledSolver which, const Model& model, const State& state, const ImplicitSystem& sys,
             std::vector<Vec3>& y);
  bool solve_lu(const Model& model, const State& state, const ImplicitSystem& sys, std::vector<Vec3>& y);
};

// Matrix-free CG preconditioned by blockdiag(A_ii)⁻¹ (the hybrid's 3×3 blocks), from the initial
// guess in y (scaled first: conjugate_gradient.cpp; y_zero: all zero, so that the first residual is
// b itself, without a product), until ‖b − A y‖/‖b‖ ≤ tolerance or `cap` iterations; fills stats.
// The product runs over sys.part, which begin_implicit_step or assemble_blocks has brought up to
// date. Its vectors (y, r, z, p, Ap and A's diagonal blocks as structure of arrays) take
// sys.arrays, the build's scratch, which the built system no longer needs.
void conjugate_gradient(const Model& model, const Bonds& bonds, ImplicitSystem& sys, double tolerance,
                        int cap, int threads, std::vector<Vec3>& y, bool y_zero, SolveStats& stats);

// A y over the free quanta by CG's matrix-free product (its vector bond pass over sys.part, which
// must be current), for solvers that keep their vectors as 3 entries a row over a list of free
// quanta (`quanta`: row r is quanta quanta[r]): y is spread onto the quanta (kinematic rows 0),
// multiplied, and gathered back. The same bits for any thread count.
class SystemProduct {
 public:
  /// Takes A's diagonal blocks from sys; model, bonds, sys and quanta must outlive the applications.
  void prepare(const Model& model, const Bonds& bonds, const ImplicitSystem& sys, const std::vector<Index>& quanta,
               int threads);
  /// out = A y (3 · quanta.size() entries each).
  void apply(const double* y, double* out, int threads);

 private:
  const Model* model_ = nullptr;
  const Bonds* bonds_ = nullptr;
  const ImplicitSystem* sys_ = nullptr;
  const std::vector<Index>* quanta_ = nullptr;
  LineVector<double> buffer_;
  double *y_[3] = {}, *out_[3] = {}, *D_[6] = {};
};

// Block Gauss–Seidel sweeps in graph-colour order (quanta of one colour share no bond, so their
// 3×3 updates run in parallel), from the initial guess in y, at most `sweeps` or until the
// in-sweep residual estimate ‖b − A y‖/‖b‖ ≤ tolerance (tolerance > 0); optional Chebyshev
// semi-iteration (Wang 2015) when rho > 0; fills stats. Over ranks (`link`), the ghosts' rows
// are brought from their owners after each colour, and the residual is the owned rows' summed
// over the ranks.
struct GaussSeidel {
  std::vector<Vec3> prev, older;
  std::vector<double> res;  // residual² of each free quanta's block, in colour order
  void solve(const Adjacency& adj, const ImplicitSystem& sys, const Coloring& col, int sweeps, double tolerance,
             double rho, int threads, std::vector<Vec3>& y, SolveStats& stats, RanksLink* link = nullptr);
};

// Σ res[k] over the rows of col.quanta a solve counts: every one alone, the owned ones summed
// over the ranks with a link (collective then).
double residual_sum(const std::vector<double>& res, const Coloring& col, int threads, RanksLink* link);

}  // namespace qbond
