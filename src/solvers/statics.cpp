#include "qbond/solvers/statics.hpp"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>

namespace qbond {
namespace {

// Net force on every quanta: bonds (no damping: statics has no velocity), gravity, loads.
void net_forces(const Model& model, const State& state, const std::vector<Vec3>& f_ext, std::vector<Vec3>& f) {
  f = f_ext;
  for (std::size_t b = 0; b < state.bonds.size(); ++b) {
    if (!state.bonds.alive[b]) continue;
    const Index i = state.bonds.i[b], j = state.bonds.j[b];
    const Vec3 d = state.x[j] - state.x[i];
    const double r = d.norm();
    if (!(r > 0)) continue;
    const Vec3 fb = state.bonds.law_at(model.shapes, b, r, state.bonds.rest[b]).T / r * d;
    f[i] += fb;
    f[j] -= fb;
  }
}

// The total potential Π(x) = Σ_b U_b(r_b) − Σ_free f_ext · x, whose gradient is minus the net
// force on the free quanta: the line search's measure of progress.
double potential(const Model& model, const State& state, const std::vector<Vec3>& f_ext) {
  double pi = 0;
  for (std::size_t b = 0; b < state.bonds.size(); ++b) {
    if (!state.bonds.alive[b]) continue;
    const double r = (state.x[state.bonds.j[b]] - state.x[state.bonds.i[b]]).norm();
    if (r > 0) pi += state.bonds.law_at(model.shapes, b, r, state.bonds.rest[b]).U;
  }
  for (std::size_t i = 0; i < f_ext.size(); ++i)
    if (!model.is_kinematic(static_cast<Index>(i))) pi -= f_ext[i].dot(state.x[i]);
  return pi;
}

double free_norm(const Model& model, const std::vector<Vec3>& f) {
  double s = 0;
  for (std::size_t i = 0; i < f.size(); ++i)
    if (!model.is_kinematic(static_cast<Index>(i))) s += f[i].squaredNorm();
  return std::sqrt(s);
}

constexpr Eigen::Index kDirectLimit = 60000;

}  // namespace

Eigen::SparseMatrix<double> stiffness_matrix(const Model& model, const State& state, std::vector<Eigen::Index>& dof) {
  const std::size_t n = model.num_quanta();
  dof.assign(n, -1);
  Eigen::Index rows = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (!model.is_kinematic(static_cast<Index>(i))) {
      dof[i] = rows;
      rows += 3;
    }
  std::vector<Eigen::Triplet<double>> t;
  auto add = [&](Eigen::Index p, Eigen::Index q, const Mat3& m) {
    if (p < 0 || q < 0) return;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) t.emplace_back(p + r, q + c, m(r, c));
  };
  for (std::size_t b = 0; b < state.bonds.size(); ++b) {
    if (!state.bonds.alive[b]) continue;
    const Index i = state.bonds.i[b], j = state.bonds.j[b];
    const Vec3 d = state.x[j] - state.x[i];
    const double r = d.norm();
    if (!(r > 0)) continue;
    const LawValue lv = state.bonds.law_at(model.shapes, b, r, state.bonds.rest[b]);
    const Mat3 Kb = stiffness_block(lv.T, lv.dT, r, d / r, /*clamp_for_solver=*/false);
    add(dof[i], dof[i], Kb);
    add(dof[j], dof[j], Kb);
    add(dof[i], dof[j], -Kb);
    add(dof[j], dof[i], -Kb);
  }
  Eigen::SparseMatrix<double> K(rows, rows);
  K.setFromTriplets(t.begin(), t.end());
  return K;
}

StaticResult solve_static(World& world, double tolerance, int max_iterations) {
  const Model& model = world.model;
  State& state = world.state;
  const std::size_t n = model.num_quanta();
  std::vector<Vec3> f_ext(n), f, x0;
  for (std::size_t i = 0; i < n; ++i) f_ext[i] = model.mass[i] * model.gravity;
  for (const Load& load : model.loads)
    for (Index i : load.quanta) f_ext[i] += load.share();
  for (std::size_t i = 0; i < n; ++i)
    if (!model.is_kinematic(static_cast<Index>(i))) state.v[i].setZero();

  StaticResult res;
  net_forces(model, state, f_ext, f);
  // Relative to the loads, or, when there are none (a structure strained by its anchors), to
  // the net force the start state has.
  const double scale = std::max({free_norm(model, f_ext), free_norm(model, f), 1e-300});
  res.residual = free_norm(model, f) / scale;
  std::vector<Eigen::Index> dof;
  Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper,
                           Eigen::IncompleteCholesky<double>>
      cg;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  std::vector<Vec3> best = state.x;
  double best_residual = res.residual;
  while (res.residual > tolerance && res.iterations < max_iterations) {
    const Eigen::SparseMatrix<double> K = stiffness_matrix(model, state, dof);
    Eigen::VectorXd rhs(K.rows());
    for (std::size_t i = 0; i < n; ++i)
      if (dof[i] >= 0) rhs.segment<3>(dof[i]) = f[i];
    // K dx = f, so that f(x + dx) ≈ f - K dx = 0. Sparse LDLᵀ up to kDirectLimit unknowns (fast
    // and exact there, and indefinite K from compressed bonds is fine), with a shift far below
    // any physical stiffness so that directions that resist nothing and carry no force (a
    // straight chain sideways) stay put; beyond, whose fill-in would not fit, preconditioned CG.
    Eigen::VectorXd dx;
    if (K.rows() <= kDirectLimit) {
      ldlt.setShift(1e-12 * K.diagonal().cwiseAbs().maxCoeff());
      ldlt.compute(K);
      dx = ldlt.solve(rhs);
    } else {
      cg.setTolerance(std::max(0.01 * tolerance, 1e-15));
      cg.compute(K);
      dx = cg.solve(rhs);
    }
    if (!dx.allFinite()) break;
    // Backtrack until the step makes progress: the residual drops, or the total potential does
    // by Armijo's rule (Π(x + s dx) <= Π(x) − 1e-4 s f·dx, when dx descends). The residual
    // alone stalls on bending: a Newton step rotates bonds along their tangents, which stretches
    // them by r θ²/2, and on a slender beam those forces exceed the loads by orders of magnitude
    // (the cantilever scene crept 1 % of the way in 50 halved steps) though the step lowers Π.
    x0 = state.x;
    const std::vector<Vec3> f0 = f;
    double step = 1, slope = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (dof[i] >= 0) slope -= f0[i].dot(dx.segment<3>(dof[i]));
    const double pi0 = slope < 0 ? potential(model, state, f_ext) : 0;
    const double before = res.residual;
    bool progress = false;
    for (int tries = 0; tries < 30 && !progress; ++tries, step *= 0.5) {
      for (std::size_t i = 0; i < n; ++i)
        if (dof[i] >= 0) state.x[i] = x0[i] + step * dx.segment<3>(dof[i]);
      net_forces(model, state, f_ext, f);
      res.residual = free_norm(model, f) / scale;
      progress =
          res.residual < before || (slope < 0 && potential(model, state, f_ext) <= pi0 + 1e-4 * step * slope);
    }
    ++res.iterations;
    if (res.residual < best_residual) {
      best_residual = res.residual;
      best = state.x;
    }
    if (!progress) break;  // no descent
  }
  // The shape of the smallest residual found (the last one, unless it did not converge).
  if (res.residual > best_residual) {
    state.x = best;
    res.residual = best_residual;
  }
  res.converged = res.residual <= tolerance;
  return res;
}

}  // namespace qbond
