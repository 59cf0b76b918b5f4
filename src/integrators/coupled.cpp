// Coupled implicit integrator (Eq. 13 linearised, Baraff–Witkin 1998): one global linear solve
// of (M + h C + h² K) Δv = b per step (backward_euler.hpp), by dense Gaussian elimination (the
// paper's method, cubic cost), sparse LDLᵀ, or CG preconditioned by block Jacobi (matrix-free)
// or by multigrid (multigrid_step.hpp).
#include <cassert>

#include "integrators/backward_euler.hpp"
#include "integrators/contact_solve.hpp"
#include "integrators/integrator_common.hpp"
#include "integrators/multigrid_step.hpp"

namespace qbond {
namespace {

class CoupledIntegrator final : public StepIntegrator {
 public:
  // Dampers at the end-of-step velocity (backward Euler).
  explicit CoupledIntegrator(const IntegratorConfig& c) : StepIntegrator(c, {.damping_theta = 1.0}) {}

  bool forms_gravity() const override { return true; }

  void project(const Model& model, const State& state, const Adjacency& adj,
               const std::vector<Vec3>& f_ext, const StepContext& ctx, Projection& out) override {
    begin_implicit_step(model, state, adj, f_ext, ctx, /*edges=*/false, config_.threads, out, sys_);
    const bool contacts = contact_.begin(model, state, f_ext, ctx.h, config_.threads, sys_);
    solve(model, state, adj, f_ext, ctx);
    // Contacts: solved again, from the last solution, while the active set changes.
    for (int pass = 1;
         contacts && pass < kContactPasses && contact_.update(model, state, ctx.h, config_.threads, y_, sys_); ++pass) {
      const SolveStats first = stats_;
      solve(model, state, adj, f_ext, ctx, /*warm=*/true);
      stats_.iterations += first.iterations;
    }
    if (config_.solver == CoupledSolver::cg) {
      if (config_.restore_momentum)
        restore_component_momentum(model, topo_.components, f_ext, ctx.h, y_, contact_.touching());
      keep_guess(config_.warm_start, y_, ctx.h, state.carry, config_.threads, out);
    }
    write_free_rows(model, state, ctx.h, y_, config_.threads, out);
    if (contacts) contact_.finish(model, state, ctx.h, y_, out);
  }

 private:
  // Active-set passes of a step with contacts at most (each a solve).
  static constexpr int kContactPasses = 8;

  // One solve of the step's system into y_; `warm`: from y_ itself (a contact pass).
  void solve(const Model& model, const State& state, const Adjacency& adj, const std::vector<Vec3>& f_ext,
             const StepContext& ctx, bool warm = false) {
    stats_ = {};
    switch (config_.solver) {
      case CoupledSolver::dense:
      case CoupledSolver::ldlt:
        direct_.solve(config_.solver, model, state, sys_, y_);
        break;
      case CoupledSolver::cg: {
        topo_.update(model, adj);
        const bool guessed =
            warm || initial_guess(config_.warm_start, model, f_ext, ctx.h, state.carry, config_.threads, y_);
        if (use_multigrid(model)) {
          multigrid_.solve(model, state, adj, sys_, ctx.h, config_.tolerance, cg_cap(config_, topo_), config_.threads,
                           y_, !guessed, stats_);
          // Steps so small that block Jacobi would converge as fast: back to it (the hierarchy is kept).
          if (stats_.iterations <= 2) slow_jacobi_ = false;
        }
        else
        {
          conjugate_gradient(model, state.bonds, sys_, config_.tolerance, cg_cap(config_, topo_), config_.threads, y_,
                             !guessed, stats_);
          slow_jacobi_ = stats_.iterations > kMultigridAfter;
          jacobi_quanta_ = model.num_quanta();
        }
        break;
      }
      case CoupledSolver::sweep:
        assert(false && "make_integrator rejects coupled_implicit with sweep");
        break;
    }
  }

  // multigrid as asked, or (automatic) once block Jacobi was slow on this body: a hierarchy is
  // then kept and pays for its set-up over the following steps.
  bool use_multigrid(const Model& model) {
    if (config_.preconditioner != Preconditioner::automatic) return config_.preconditioner == Preconditioner::multigrid;
    if (model.num_quanta() != jacobi_quanta_) slow_jacobi_ = false;  // another body: block Jacobi first
    return slow_jacobi_;
  }

  ImplicitSystem sys_;
  ContactSolve contact_;
  bool slow_jacobi_ = false;        // the last block-Jacobi solve took more than kMultigridAfter iterations
  std::size_t jacobi_quanta_ = 0;   // the quanta then
  TopologyCache topo_;
  std::vector<Vec3> y_;
  DirectSolver direct_;
  MultigridStep multigrid_;
};

}  // namespace

std::unique_ptr<StepIntegrator> make_coupled_implicit_integrator(const IntegratorConfig& config) {
  return std::make_unique<CoupledIntegrator>(config);
}

}  // namespace qbond
