// The paper's hybrid implicit integrator (Eqs. 11–12): one 3×3 solve per quanta.
//   frozen: neighbours at rest at their start positions (the paper literally), one pass;
//   sweep:  block Gauss–Seidel on the coupled system (backward_euler.hpp) in colour order,
//           optionally Chebyshev-accelerated (Wang 2015, as in Vertex Block Descent);
//   jacobi: block Jacobi on the coupled system.
#include <cmath>

#include "integrators/backward_euler.hpp"
#include "integrators/integrator_common.hpp"
#include "integrators/ranks_link.hpp"
#include "core/parallel.hpp"

namespace qbond {
namespace {

class HybridIntegrator final : public StepIntegrator {
 public:
  // Dampers at the end-of-step velocity (backward Euler).
  explicit HybridIntegrator(const IntegratorConfig& c) : StepIntegrator(c, {.damping_theta = 1.0}) {}

  bool forms_gravity() const override { return config_.neighbours == NeighbourModel::frozen; }

  // The frozen step's fused kernel writes the state the step applies in its solve pass; the
  // sweeps' step adds its solution to the state in the pass that forms its rows (apply_solved).
  void advance(const Model& model, const State& state, const Adjacency& adj, const std::vector<Vec3>& f_ext,
               const StepContext& ctx, Projection& out, Advanced& to) override {
    stats_ = {};
    if (config_.neighbours != NeighbourModel::frozen) {
      solve(model, state, adj, f_ext, ctx, out);
      apply_solved(model, state, out, y_, ctx.h, ctx.t + ctx.h, config_.threads, placed_, to);
      return;
    }
    frozen_.project(model, state, adj, f_ext, ctx, config_.threads, out, &to);
    stats_.iterations = 1;
  }

  void project(const Model& model, const State& state, const Adjacency& adj,
               const std::vector<Vec3>& f_ext, const StepContext& ctx, Projection& out) override {
    const int threads = config_.threads;
    stats_ = {};
    if (config_.neighbours == NeighbourModel::frozen) {
      frozen_.project(model, state, adj, f_ext, ctx, threads, out, nullptr);
      stats_.iterations = 1;
      return;
    }
    solve(model, state, adj, f_ext, ctx, out);
    write_free_rows(model, state, ctx.h, y_, threads, out);
  }

 private:
  // The coupled system's step by sweeps or Jacobi: its solution Δv into y_, the kinematic rows
  // and the carry-over into `out` (the free rows are the caller's to write).
  void solve(const Model& model, const State& state, const Adjacency& adj, const std::vector<Vec3>& f_ext,
             const StepContext& ctx, Projection& out) {
    const int threads = config_.threads;
    begin_implicit_step(model, state, adj, f_ext, ctx, /*edges=*/true, threads, out, sys_);
    if (ranks_) {
      // ‖b‖ of the whole system: the owned rows', summed over the ranks.
      const std::vector<std::uint8_t>& owned = ranks_->owned();
      double b2 = deterministic_sum(model.num_quanta(), threads,
                                    [&](std::size_t i) { return owned[i] ? sys_.rhs[i].squaredNorm() : 0.0; });
      ranks_->sum({&b2, 1});
      sys_.rhs_norm = std::sqrt(b2);
    } else {
      topo_.update(model, adj);
    }
    const Coloring& col = ranks_ ? ranks_->coloring() : topo_.coloring;
    initial_guess(config_.warm_start, model, f_ext, ctx.h, state.carry, threads, y_);
    if (config_.neighbours == NeighbourModel::sweep)
      gs_.solve(adj, sys_, col, config_.iterations, config_.tolerance, config_.chebyshev_rho, threads, y_, stats_,
                ranks_);
    else
      jacobi(adj, col);
    if (config_.restore_momentum) {
      if (ranks_) {
        ranks_->restore_momentum(model, f_ext, ctx.h, y_);
        ranks_->exchange(y_);
      } else {
        restore_component_momentum(model, topo_.components, f_ext, ctx.h, y_);
      }
    }
    keep_guess(config_.warm_start, y_, ctx.h, state.carry, threads, out);
  }

  // b_i + Σ_b B_b y_j over i's bonds to free quanta (kinematic unknowns are eliminated).
  Vec3 gathered_rhs(const Adjacency& adj, Index i, const std::vector<Vec3>& y) const {
    return sys_.rhs[i] + neighbours_times(adj, sys_, i, y);
  }

  bool converged(double residual2) {
    stats_.residual = sys_.rhs_norm > 0 ? std::sqrt(residual2) / sys_.rhs_norm : std::sqrt(residual2);
    return config_.tolerance > 0 && stats_.residual <= config_.tolerance;
  }

  void jacobi(const Adjacency& adj, const Coloring& col) {
    const std::vector<Index>& free = col.quanta;
    res_.resize(free.size());
    for (int it = 0; it < config_.iterations; ++it) {
      next_ = y_;
      parallel_for(free.size(), config_.threads, [&](std::size_t k) {
        const Index i = free[k];
        const Vec3 r = gathered_rhs(adj, i, y_);
        res_[k] = (r - sys_.diag[i] * y_[i]).squaredNorm();
        next_[i] = sys_.diag_inv[i] * r;
      });
      if (ranks_) ranks_->exchange(next_);
      y_.swap(next_);
      stats_.iterations = it + 1;
      if (converged(residual_sum(res_, col, config_.threads, ranks_))) break;
    }
  }

  ImplicitSystem sys_;
  FrozenStep frozen_;
  TopologyCache topo_;
  GaussSeidel gs_;
  std::vector<Vec3> y_, next_;
  std::vector<double> res_;  // jacobi: residual² of each free quanta's block
  PrescribedAt placed_;      // apply_solved's
};

std::unique_ptr<StepIntegrator> make_hybrid(const IntegratorConfig& config) {
  return std::make_unique<HybridIntegrator>(config);
}

}  // namespace


const IntegratorInfo hybrid_implicit_integrator = {
    IntegratorType::hybrid_implicit, "hybrid_implicit", "Eqs. 11-12: one 3x3 solve per quanta (see neighbours)", {},
    kEveryWarmStart, make_hybrid};

}  // namespace qbond
