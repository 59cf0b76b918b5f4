#include "implicit_system.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "parallel.hpp"

namespace qbond {

void begin_implicit_step(const Model& model, const State& state, const Adjacency& adj,
                         const std::vector<Vec3>& f_ext, const StepContext& ctx, bool edges, int threads,
                         Projection& kin, ImplicitSystem& sys) {
  const std::size_t n = model.num_quanta();
  kin.resize(n);
  project_kinematic(model, state, ctx, kin);
  const double h = ctx.h, h2 = h * h;
  sys.part.update(model, adj, threads);
  sys.bonds.resize(model.num_bonds());
  sys.rows.resize(n);
  sys.edges.resize(edges ? adj.offset[n] : 0);
  sys.cursor.resize(edges ? n : 0);
  parallel_for(n, threads, [&](std::size_t i) {
    sys.rows[i].start(model.mass[i], h * f_ext[i]);
    if (edges) sys.cursor[i] = adj.offset[i];
  });

  // Δx₀ and Δv_k, the motion already known before solving (see the header).
  auto dx0 = [&](Index i) -> Vec3 { return model.is_kinematic(i) ? kin.dx[i] : Vec3(h * state.v[i]); };
  auto dvk = [&](Index i) -> Vec3 { return model.is_kinematic(i) ? kin.dv[i] : Vec3::Zero(); };

  // Per bond: u, B_b (written by the part owning bond_i) and g_b, the right-hand-side term on i
  // (j gets −g_b). A quanta's bonds come in bond order, the order of its adjacency entries: its
  // cursor walks them.
  for_each_bond(sys.part, model, [&](Index b, bool own_i, bool own_j) {
    const Index i = model.bond_i[b], j = model.bond_j[b];
    const bool free_i = !model.is_kinematic(i), free_j = !model.is_kinematic(j);
    const bool write_block = own_i && (free_i || free_j);
    own_i = own_i && free_i;  // kinematic rows are not solved for
    own_j = own_j && free_j;
    if (!own_i && !own_j && !write_block) return;
    const BondLinearisation l = linearise_bond(model, state, b);
    const double Ba = h * l.ca + h2 * l.ka, Bb = h * l.cb + h2 * l.kb;
    if (write_block) sys.bonds.set(b, l.u, Ba, Bb);
    if (!own_i && !own_j) return;
    double B[6];
    block_entries(l.u, Ba, Bb, B);
    Vec3 g = h * l.f - h * block_times(l.u, l.ka, l.kb, dx0(i) - dx0(j));
    if (!free_i || !free_j) g -= h * block_times(l.u, l.ca, l.cb, dvk(i) - dvk(j));  // Δv_k = 0 for free quanta
    // An edge towards a kinematic neighbour is 0: its unknown is eliminated.
    if (own_i) {
      DiagonalRow& row = sys.rows[i];
      row.add_block(B);
      row.b += g;
      if (edges) sys.edges[sys.cursor[i]++] = {l.u, free_j ? Ba : 0.0, free_j ? Bb : 0.0};
    }
    if (own_j) {
      DiagonalRow& row = sys.rows[j];
      row.add_block(B);
      row.b -= g;
      if (edges) sys.edges[sys.cursor[j]++] = {l.u, free_i ? Ba : 0.0, free_i ? Bb : 0.0};
    }
  });
  sys.diag.resize(n);
  sys.diag_inv.resize(n);
  sys.rhs.resize(n);
  parallel_for(n, threads, [&](std::size_t q) {
    const auto i = static_cast<Index>(q);
    if (model.is_kinematic(i)) {
      sys.diag[i].setIdentity();
      sys.diag_inv[i].setIdentity();
      sys.rhs[i].setZero();
      return;
    }
    sys.diag[i] = sys.rows[i].matrix();
    // A_ii = m I + Σ B_b with B_b positive semi-definite: symmetric positive definite.
    sys.diag_inv[i] = sys.diag[i].inverse();
    sys.rhs[i] = sys.rows[i].b;
  });
  sys.rhs_norm = std::sqrt(deterministic_sum(n, threads, [&](std::size_t i) { return sys.rhs[i].squaredNorm(); }));
}

void assemble_blocks(const Model& model, const Adjacency& adj, int threads, ImplicitSystem& sys) {
  const std::size_t n = model.num_quanta();
  sys.part.update(model, adj, threads);
  sys.diag.resize(n);
  sys.diag_inv.resize(n);
  sys.edges.resize(adj.offset[n]);
  parallel_for(n, threads, [&](std::size_t q) {
    const auto i = static_cast<Index>(q);
    if (model.is_kinematic(i)) {
      sys.diag[i].setIdentity();
      sys.diag_inv[i].setIdentity();
      return;
    }
    Mat3 d = model.mass[i] * Mat3::Identity();
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
      const Index b = adj.bond[e];
      const Vec3 u = sys.bonds.u(b);
      const double Ba = sys.bonds.Ba[b], Bb = sys.bonds.Bb[b];
      d += block_matrix(u, Ba, Bb);
      const bool coupled = !model.is_kinematic(adj.other[e]);
      sys.edges[e] = {u, coupled ? Ba : 0.0, coupled ? Bb : 0.0};
    }
    sys.diag[i] = d;
    // A_ii = m I + Σ B_b with B_b positive semi-definite: symmetric positive definite.
    sys.diag_inv[i] = d.inverse();
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
  assert(!exact || sys.exact.size() == model.num_bonds());
  for (std::size_t i = 0; i < n; ++i)
    if (dof[i] >= 0) {
      b.segment<3>(dof[i]) = sys.rhs[i];
      add_block(dof[i], dof[i], exact ? Mat3(model.mass[i] * Mat3::Identity()) : sys.diag[i]);
    }
  for (std::size_t k = 0; k < model.num_bonds(); ++k) {
    const Eigen::Index p = dof[model.bond_i[k]], q = dof[model.bond_j[k]];
    if (!state.alive[k] || (p < 0 && q < 0)) continue;
    const Mat3 B = exact ? sys.exact[k] : block_matrix(sys.bonds.u(k), sys.bonds.Ba[k], sys.bonds.Bb[k]);
    if (exact) {  // sys.diag holds the a u uᵀ + b I blocks' sums: the diagonal is summed here
      if (p >= 0) add_block(p, p, B);
      if (q >= 0) add_block(q, q, B);
    }
    if (p < 0 || q < 0) continue;
    add_block(p, q, -B);
    add_block(q, p, -B);
  }
  A.resize(3 * nf, 3 * nf);
  A.setFromTriplets(triplets.begin(), triplets.end());
  return nf;
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
    ldlt.compute(A);
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
  lu.compute(A);  // the ordering is recomputed too: bonds break between steps
  if (lu.info() != Eigen::Success) return false;
  const Eigen::VectorXd sol = lu.solve(b);
  if (!sol.allFinite()) return false;
  for (std::size_t i = 0; i < n; ++i)
    if (dof[i] >= 0) y[i] = sol.segment<3>(dof[i]);
  return true;
}

void GaussSeidel::solve(const Adjacency& adj, const ImplicitSystem& sys, const Coloring& col, int sweeps,
                        double tolerance, double rho, int threads, std::vector<Vec3>& y, SolveStats& stats) {
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
    const double r2 = deterministic_sum(res.size(), threads, [&](std::size_t k) { return res[k]; });
    stats.residual = sys.rhs_norm > 0 ? std::sqrt(r2) / sys.rhs_norm : std::sqrt(r2);
    if (tolerance > 0 && stats.residual <= tolerance) break;
  }
}

}  // namespace qbond
