// Coupled implicit integrator (Eq. 13 linearised, Baraff–Witkin 1998): one global linear solve
// of (M + h C + h² K) Δv = b per step (implicit_system.hpp), by dense Gaussian elimination (the
// paper's method, cubic cost), sparse LDLᵀ, or matrix-free block-Jacobi-preconditioned CG.
#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <cmath>

#include "implicit_system.hpp"
#include "integrator_common.hpp"
#include "parallel.hpp"

namespace qbond {
namespace {

class CoupledIntegrator final : public Integrator {
 public:
  explicit CoupledIntegrator(const IntegratorConfig& c) : Integrator(c) {}

  double damping_theta() const override { return 1.0; }

  void project(const Model& model, const State& state, const Adjacency& adj,
               const std::vector<Vec3>& f_ext, const StepContext& ctx, Projection& out) override {
    begin_implicit_step(model, state, adj, f_ext, ctx, /*frozen=*/false, config_.threads, out, sys_);
    stats_ = {};
    switch (config_.solver) {
      case CoupledSolver::dense:
      case CoupledSolver::ldlt:
        solve_direct(model, state);
        break;
      case CoupledSolver::cg:
        topo_.update(model, adj);
        initial_guess(config_.warm_start, model, f_ext, ctx.h, state.warm, y_);
        conjugate_gradient(model, adj);
        if (config_.restore_momentum)
          restore_component_momentum(model, topo_.components, f_ext, ctx.h, y_);
        if (config_.warm_start == WarmStart::previous) out.warm = y_;
        break;
    }
    write_free_rows(model, state, ctx.h, y_, out);
  }

 private:
  void solve_direct(const Model& model, const State& state) {
    const std::size_t n = model.num_quanta();
    const Eigen::Index nf = assemble_system(model, state, sys_, dof_, triplets_, A_, b_);
    y_.assign(n, Vec3::Zero());
    if (nf == 0) return;
    Eigen::VectorXd sol;
    if (config_.solver == CoupledSolver::dense) {
      sol = Eigen::MatrixXd(A_).partialPivLu().solve(b_);  // Gaussian elimination, partial pivoting
    } else {
      ldlt_.compute(A_);
      sol = ldlt_.solve(b_);
    }
    for (std::size_t i = 0; i < n; ++i)
      if (dof_[i] >= 0) y_[i] = sol.segment<3>(dof_[i]);
  }

  // Σ a_i · b_i over free quanta (kinematic rows of r, z, p and Ap are 0).
  double dot(const std::vector<Vec3>& a, const std::vector<Vec3>& b) const {
    return deterministic_sum(a.size(), config_.threads, [&](std::size_t i) { return a[i].dot(b[i]); });
  }

  // Preconditioned CG, preconditioner P = blockdiag(A_ii)⁻¹ (the hybrid's 3×3 blocks).
  void conjugate_gradient(const Model& model, const Adjacency& adj) {
    const std::size_t n = model.num_quanta();
    const int threads = config_.threads;
    const int cap = config_.max_iterations > 0 ? config_.max_iterations
                                               : static_cast<int>(3 * topo_.coloring.quanta.size());
    apply_system(model, adj, sys_, y_, threads, Ap_);
    r_.resize(n);
    z_.resize(n);
    p_.resize(n);
    parallel_for(n, threads, [&](std::size_t i) {
      r_[i] = model.is_kinematic(static_cast<Index>(i)) ? Vec3::Zero() : Vec3(sys_.rhs[i] - Ap_[i]);
      z_[i] = sys_.diag_inv[i] * r_[i];
      p_[i] = z_[i];
    });
    double rz = dot(r_, z_);
    const double bnorm = sys_.rhs_norm;
    auto rel = [&](double r2) { return bnorm > 0 ? std::sqrt(r2) / bnorm : std::sqrt(r2); };
    stats_.residual = rel(dot(r_, r_));
    int it = 0;
    while (it < cap && stats_.residual > config_.tolerance) {
      apply_system(model, adj, sys_, p_, threads, Ap_);
      const double pAp = dot(p_, Ap_);
      if (!(pAp > 0)) break;  // exact solution reached (p = 0) or loss of positivity
      const double alpha = rz / pAp;
      parallel_for(n, threads, [&](std::size_t i) {
        y_[i] += alpha * p_[i];
        r_[i] -= alpha * Ap_[i];
        z_[i] = sys_.diag_inv[i] * r_[i];
      });
      const double rz_new = dot(r_, z_);
      const double beta = rz_new / rz;
      rz = rz_new;
      parallel_for(n, threads, [&](std::size_t i) { p_[i] = z_[i] + beta * p_[i]; });
      ++it;
      stats_.residual = rel(dot(r_, r_));
    }
    stats_.iterations = it;
  }

  ImplicitSystem sys_;
  TopologyCache topo_;
  std::vector<Vec3> y_, r_, z_, p_, Ap_;
  std::vector<Eigen::Index> dof_;
  std::vector<Eigen::Triplet<double>> triplets_;
  Eigen::SparseMatrix<double> A_;
  Eigen::VectorXd b_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt_;
};

}  // namespace

std::unique_ptr<Integrator> make_coupled_implicit_integrator(const IntegratorConfig& config) {
  return std::make_unique<CoupledIntegrator>(config);
}

}  // namespace qbond
