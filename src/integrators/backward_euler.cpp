#include "integrators/backward_euler.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <span>

#include "core/parallel.hpp"

namespace qbond {

void gather_edges(const Model& model, const Adjacency& adj, int threads, ImplicitSystem& sys) {
  const std::size_t n = model.num_quanta();
  sys.edges.resize(adj.offset[n]);
  parallel_for(n, threads, [&](std::size_t q) {
    const auto i = static_cast<Index>(q);
    if (model.is_kinematic(i)) return;
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
      const Index b = adj.bond[e];
      const bool coupled = !model.is_kinematic(adj.other[e]);
      sys.edges[e] = {sys.bonds.u(b), coupled ? sys.bonds.Ba[b] : 0.0, coupled ? sys.bonds.Bb[b] : 0.0};
    }
  });
}

Eigen::Index assemble_system(const Model& model, const State& state, const ImplicitSystem& sys,
                             std::vector<Eigen::Index>& dof, std::vector<Eigen::Triplet<double>>& triplets,
                             Eigen::SparseMatrix<double>& A, Eigen::VectorXd& b) {
  const std::size_t n = model.num_quanta();
  dof.assign(n, -1);
  Eigen::Index nf = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (!model.is_kinematic(static_cast<Index>(i))) dof[i] = 3 * nf++;
  b.resize(3 * nf);
  triplets.clear();
  auto add_block = [&](Eigen::Index p, Eigen::Index q, const Mat3& m) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) triplets.emplace_back(p + r, q + c, m(r, c));
  };
  const bool exact = !sys.exact.empty();
  assert(!exact || sys.exact.size() == state.bonds.size());
  for (std::size_t i = 0; i < n; ++i)
    if (dof[i] >= 0) {
      b.segment<3>(dof[i]) = sys.rhs[i];
      add_block(dof[i], dof[i], exact ? Mat3(model.mass[i] * Mat3::Identity()) : sys.diag[i]);
    }
  for (std::size_t k = 0; k < state.bonds.size(); ++k) {
    const Eigen::Index p = dof[state.bonds.i[k]], q = dof[state.bonds.j[k]];
    if (!state.bonds.alive[k] || (p < 0 && q < 0)) continue;
    const Mat3 B = exact ? sys.exact[k] : block_matrix(sys.bonds.u(k), sys.bonds.Ba[k], sys.bonds.Bb[k]);
    if (exact) {  // sys.diag holds the a u uᵀ + b I blocks' sums: the diagonal is summed here
      if (p >= 0) add_block(p, p, B);
      if (q >= 0) add_block(q, q, B);
    }
    if (p < 0 || q < 0) continue;
    add_block(p, q, -B);
    add_block(q, p, -B);
  }
  for (const PairCoupling& c : sys.couplings) {
    const Eigen::Index p = dof[c.i], q = dof[c.j];
    if (p < 0 || q < 0) continue;
    const Mat3 B = block_matrix(c.u, c.a, c.b);
    add_block(p, q, -B);
    add_block(q, p, -B);
  }
  A.resize(3 * nf, 3 * nf);
  A.setFromTriplets(triplets.begin(), triplets.end());
  return nf;
}

bool SparsityPattern::matches(const Eigen::SparseMatrix<double>& A) {
  assert(A.isCompressed());
  const std::span<const int> o(A.outerIndexPtr(), static_cast<std::size_t>(A.outerSize()) + 1);
  const std::span<const int> in(A.innerIndexPtr(), static_cast<std::size_t>(A.nonZeros()));
  if (std::ranges::equal(o, outer) && std::ranges::equal(in, inner)) return true;
  outer.assign(o.begin(), o.end());
  inner.assign(in.begin(), in.end());
  return false;
}

void DirectSolver::solve(CoupledSolver which, const Model& model, const State& state, const ImplicitSystem& sys,
                         std::vector<Vec3>& y) {
  const std::size_t n = model.num_quanta();
  const Eigen::Index nf = assemble_system(model, state, sys, dof, triplets, A, b);
  y.assign(n, Vec3::Zero());
  if (nf == 0) return;
  Eigen::VectorXd sol;
  if (which == CoupledSolver::dense) {
    sol = Eigen::MatrixXd(A).partialPivLu().solve(b);  // Gaussian elimination, partial pivoting
  } else {
    if (!ldlt_pattern.matches(A)) ldlt.analyzePattern(A);
    ldlt.factorize(A);
    sol = ldlt.solve(b);
  }
  for (std::size_t i = 0; i < n; ++i)
    if (dof[i] >= 0) y[i] = sol.segment<3>(dof[i]);
}

bool DirectSolver::solve_lu(const Model& model, const State& state, const ImplicitSystem& sys, std::vector<Vec3>& y) {
  const std::size_t n = model.num_quanta();
  const Eigen::Index nf = assemble_system(model, state, sys, dof, triplets, A, b);
  y.assign(n, Vec3::Zero());
  if (nf == 0) return true;
  if (!lu_pattern.matches(A)) lu.analyzePattern(A);
  lu.factorize(A);
  if (lu.info() != Eigen::Success) return false;
  const Eigen::VectorXd sol = lu.solve(b);
  if (!sol.allFinite()) return false;
  for (std::size_t i = 0; i < n; ++i)
    if (dof[i] >= 0) y[i] = sol.segment<3>(dof[i]);
  return true;
}

double residual_sum(const std::vector<double>& res, const Coloring& col, int threads, RanksLink* link) {
  if (!link) return deterministic_sum(res.size(), threads, [&](std::size_t k) { return res[k]; });
  const std::vector<std::uint8_t>& owned = link->owned();
  double r2 = deterministic_sum(res.size(), threads, [&](std::size_t k) { return owned[col.quanta[k]] ? res[k] : 0.0; });
  link->sum({&r2, 1});
  return r2;
}

void GaussSeidel::solve(const Adjacency& adj, const ImplicitSystem& sys, const Coloring& col, int sweeps,
                        double tolerance, double rho, int threads, std::vector<Vec3>& y, SolveStats& stats,
                        RanksLink* link) {
  double omega = 1;
  if (rho > 0) older = y;
  res.resize(col.quanta.size());
  for (int it = 0; it < sweeps; ++it) {
    if (rho > 0) prev = y;
    // The residual of each block just before its update; summed, the usual in-sweep estimate.
    for (std::size_t c = 0; c < col.num_colors(); ++c) {
      // Quanta of one colour share no bond: their updates are independent.
      const Index begin = col.offset[c];
      parallel_for(col.offset[c + 1] - begin, threads, [&](std::size_t q) {
        const Index k = begin + static_cast<Index>(q);
        const Index i = col.quanta[k];
        const Vec3 r = sys.rhs[i] + neighbours_times(adj, sys, i, y);
        res[k] = (r - sys.diag[i] * y[i]).squaredNorm();
        y[i] = sys.diag_inv[i] * r;
      });
      if (link) link->exchange(y);
    }
    if (rho > 0) {
      // Chebyshev semi-iteration: y ← ω (ŷ - y_{k-1}) + y_{k-1}.
      omega = it == 0 ? 1.0 : it == 1 ? 2.0 / (2.0 - rho * rho) : 4.0 / (4.0 - rho * rho * omega);
      parallel_for(col.quanta.size(), threads, [&](std::size_t k) {
        const Index i = col.quanta[k];
        y[i] = omega * (y[i] - older[i]) + older[i];
      });
      older.swap(prev);
    }
    stats.iterations = it + 1;
    const double r2 = residual_sum(res, col, threads, link);
    stats.residual = sys.rhs_norm > 0 ? std::sqrt(r2) / sys.rhs_norm : std::sqrt(r2);
    if (tolerance > 0 && stats.residual <= tolerance) break;
  }
}

}  // namespace qbond
