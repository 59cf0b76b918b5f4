// Coupled implicit integrator (Eq. 13 linearised, Baraff–Witkin 1998): one global linear solve
// of (M + h C + h² K) Δv = b per step (backward_euler.hpp), by dense Gaussian elimination (the
// paper's method, cubic cost), sparse LDLᵀ, or CG preconditioned by block Jacobi (matrix-free)
// or by multigrid (multigrid_step.hpp); contacts (obstacles, quanta pairs) add their penalty springs to the
// system (contact_solve.hpp), solved again while the active set changes. A step that would create energy (bonds turning far in
// one step, where the linearisation fails), found by Simulation's energy guard, is taken again
// in halves, each checked by energy_guard.hpp.
#include <algorithm>
#include <cassert>
#include <optional>

#include "integrators/backward_euler.hpp"
#include "integrators/contact_solve.hpp"
#include "integrators/energy_guard.hpp"
#include "integrators/integrator_common.hpp"
#include "integrators/multigrid_step.hpp"
#include "integrators/preconditioner_choice.hpp"

namespace qbond {
namespace {

// A substep creating more than this fraction of the magnitudes of its energy terms is
// split in two; below it, the difference is the solve's own error (CG stops at a relative
// residual, momentum restoration shifts velocities by that error) and round-off, not the
// linearisation.
constexpr double kGainTolerance = 1e-9;
// Halvings of a step that creates energy, at most (2^kMaxDepth substeps of h / 2^kMaxDepth).
constexpr int kMaxDepth = 10;

class CoupledIntegrator final : public StepIntegrator {
 public:
  // Dampers at the end-of-step velocity (backward Euler).
  explicit CoupledIntegrator(const IntegratorConfig& c) : StepIntegrator(c, {.damping_theta = 1.0, .backward_euler = true}) {}

  bool forms_gravity() const override { return true; }

  void forget_history() override {
    multigrid_.reset();
    choice_ = {};
  }

  bool splits_gaining_steps() const override { return true; }
  void split_next_step() override { split_ = true; }

  void project(const Model& model, const State& state, const Adjacency& adj,
               const std::vector<Vec3>& f_ext, const StepContext& ctx, Projection& out) override {
    stats_ = {};
    if (!split_) return solve(model, state, adj, f_ext, ctx, /*whole=*/true, out);
    // The whole step created energy (Simulation's guard): taken again as two halves, each from
    // the state the one before reached, and each split again while it creates energy. Kinematic
    // rows keep the whole step's prescribed motion; the carry-over is the whole step's Δv.
    split_ = false;
    const std::size_t n = model.num_quanta();
    out.resize(n);
    project_kinematic(model, state, ctx, out);
    sub_ = state;
    split_contact_ = {};
    split_kinetic_loss_ = 0;
    whole_h_ = ctx.h;
    const double t0 = ctx.t, t1 = ctx.t + ctx.h, tm = t0 + 0.5 * ctx.h;
    substep(model, adj, f_ext, t0, tm, ctx.step, 1);
    substep(model, adj, f_ext, tm, t1, ctx.step, 1);
    for (std::size_t i = 0; i < n; ++i) {
      if (model.is_kinematic(static_cast<Index>(i))) continue;
      out.dx[i] = sub_.x[i] - state.x[i];
      out.dv[i] = sub_.v[i] - state.v[i];
    }
    out.contact = split_contact_;  // the substeps' contacts: what they took, the springs' energy at the end
    out.kinetic_loss = split_kinetic_loss_;
    if (config_.solver == CoupledSolver::cg) keep_guess(config_.warm_start, out.dv, ctx.h, state.carry, config_.threads, out);
  }

 private:
  // One linearised backward-Euler step of length ctx.h from `state` into `out`, with the
  // obstacles' contacts in its system. A whole step starts CG from the warm start and may use the
  // multigrid hierarchy; a substep starts from zero with block Jacobi (a hierarchy is kept for the
  // whole step's length).
  void solve(const Model& model, const State& state, const Adjacency& adj, const std::vector<Vec3>& f_ext,
             const StepContext& ctx, bool whole, Projection& out) {
    begin_implicit_step(model, state, adj, f_ext, ctx, /*edges=*/false, config_.threads, out, sys_);
    const bool contacts =
        contact_.begin(model, state, adj, f_ext, ctx.h, whole ? ctx.h : whole_h_, config_.threads, sys_);
    Iterations step;
    linear_solve(model, state, adj, f_ext, ctx, whole, contacts, /*warm=*/false, step);
    // Contacts: solved again, from the last solution, while the active set changes.
    auto changed = [&](bool last) {
      return contact_.update(model, state, ctx.h, config_.threads, last, y_, sys_) ||
             contact_.admit(model, state, ctx.h, config_.threads, last, y_, sys_);
    };
    for (int pass = 1; contacts && pass < ContactSolve::kPasses && changed(pass + 1 == ContactSolve::kPasses);
         ++pass) {
      // A block-Jacobi pass that took long (an impact's stiff springs) may turn `automatic` to
      // multigrid for the step's remaining passes.
      if (whole && automatic() && step.jacobi_mean() > kMultigridAfter && !choice_.multigrid(model.num_quanta()))
        choice_.after_jacobi(step.jacobi_mean());
      linear_solve(model, state, adj, f_ext, ctx, whole, contacts, /*warm=*/true, step);
    }
    if (config_.solver == CoupledSolver::cg) {
      // `automatic` compares a whole step's solves with each preconditioner, their mean iterations
      // (the hierarchy is kept if it turns to block Jacobi). A step that has both turned to
      // multigrid within it, where its block-Jacobi solves were judged.
      if (whole && automatic()) {
        if (step.jacobi_solves > 0 && step.multigrid_solves == 0) choice_.after_jacobi(step.jacobi_mean());
        if (step.multigrid_solves > 0) choice_.after_multigrid(step.multigrid_mean());
      }
      if (config_.restore_momentum)
        restore_component_momentum(model, topo_.components, f_ext, ctx.h, y_, contact_.touching());
      if (whole) keep_guess(config_.warm_start, y_, ctx.h, state.carry, config_.threads, out);
    }
    write_free_rows(model, state, ctx.h, y_, config_.threads, out);
    topo_.update(model, adj);
    fall_freely(model, topo_.components, f_ext, ctx.h, contact_.touching(), out);
    if (contacts) contact_.finish(model, state, adj, ctx.h, y_, out);
    out.kinetic_loss = kinetic_loss(model, adj, out, config_.threads);
    stats_.iterations += step.jacobi + step.multigrid;
    stats_.residual = std::max(stats_.residual, step.residual);
  }

  // A step's solves: CG's iterations and solves by preconditioner, the last solve's residual.
  struct Iterations {
    int jacobi = 0, multigrid = 0, jacobi_solves = 0, multigrid_solves = 0;
    double residual = 0;
    // A solve's iterations on average, rounded up.
    int jacobi_mean() const { return (jacobi + jacobi_solves - 1) / std::max(jacobi_solves, 1); }
    int multigrid_mean() const { return (multigrid + multigrid_solves - 1) / std::max(multigrid_solves, 1); }
  };

  bool automatic() const { return config_.preconditioner == Preconditioner::automatic; }

  // One solve of the step's system into y_, its iterations added to `total`; `contacts`: sys_
  // holds contact springs; `warm`: from y_ itself (a contact pass).
  void linear_solve(const Model& model, const State& state, const Adjacency& adj, const std::vector<Vec3>& f_ext,
                    const StepContext& ctx, bool whole, bool contacts, bool warm, Iterations& total) {
    SolveStats step{};
    bool multigrid = false;
    switch (config_.solver) {
      case CoupledSolver::dense:
      case CoupledSolver::ldlt:
        direct_.solve(config_.solver, model, state, sys_, y_);
        break;
      case CoupledSolver::cg: {
        topo_.update(model, adj);
        const bool guessed = warm || (whole && initial_guess(config_.warm_start, model, f_ext, ctx.h, state.carry,
                                                             config_.threads, y_));
        if (!guessed) y_.assign(model.num_quanta(), Vec3::Zero());
        multigrid = whole && use_multigrid(model);
        if (multigrid) {
          if (!multigrid_) multigrid_.emplace();
          multigrid_->solve(model, state, adj, sys_, contacts, ctx.h, config_.tolerance, cg_cap(config_, topo_),
                            config_.threads, y_, !guessed, step);
        } else {
          conjugate_gradient(model, state.bonds, sys_, config_.tolerance, cg_cap(config_, topo_), config_.threads, y_,
                             !guessed, step);
        }
        break;
      }
      case CoupledSolver::sweep:
        assert(false && "make_integrator rejects coupled_implicit with sweep");
        break;
    }
    (multigrid ? total.multigrid : total.jacobi) += step.iterations;
    ++(multigrid ? total.multigrid_solves : total.jacobi_solves);
    total.residual = step.residual;
  }

  // Takes sub_ (the state at t0) to t1: one linearised step or, while that creates energy and
  // depth < kMaxDepth, two halves. Hands each substep taken to the ledger, when on.
  void substep(const Model& model, const Adjacency& adj, const std::vector<Vec3>& f_ext, double t0, double t1,
               std::uint64_t step, int depth) {
    const double H = t1 - t0;
    const StepContext ctx{H, t0, step};
    solve(model, sub_, adj, f_ext, ctx, /*whole=*/false, sub_out_);
    StepEnergyBalance balance = guard_.balance(model, sub_, adj, f_ext, sub_out_, H, ledger_hints(), config_.threads);
    const Projection::ContactEnergy& c = sub_out_.contact;
    balance.credit_contacts(c, solved_contacts_rub(model));
    const bool gains = balance.gains(kGainTolerance);
    if (gains && depth < kMaxDepth) {
      const double tm = t0 + 0.5 * H;
      substep(model, adj, f_ext, t0, tm, step, depth + 1);
      substep(model, adj, f_ext, tm, t1, step, depth + 1);
      return;
    }
    ++stats_.substeps;
    if (gains) ++stats_.unconverged;
    split_kinetic_loss_ += sub_out_.kinetic_loss;
    if (c.charged) {
      if (!split_contact_.charged) split_contact_.stored_start = c.stored_start;
      split_contact_.dissipated += c.dissipated;
      split_contact_.work += c.work;
      split_contact_.stored = c.stored;
      split_contact_.charged = true;
    }
    apply_substep(model, adj, f_ext, H, t1, sub_out_, sub_, sub_x1_, sub_v1_);
  }

  // multigrid as asked, or as `automatic` chooses (preconditioner_choice.hpp): a hierarchy is
  // then kept and pays for its set-up over the following steps.
  bool use_multigrid(const Model& model) {
    if (config_.preconditioner != Preconditioner::automatic) return config_.preconditioner == Preconditioner::multigrid;
    return choice_.multigrid(model.num_quanta());
  }

  ImplicitSystem sys_;
  ContactSolve contact_;
  PreconditionerChoice choice_;
  TopologyCache topo_;
  std::vector<Vec3> y_;
  DirectSolver direct_;
  std::optional<MultigridStep> multigrid_;  // made on the first multigrid solve
  EnergyGuard guard_;
  bool split_ = false;                 // split_next_step: the next projection in substeps
  State sub_;                          // substepping: the state the substeps have reached
  Projection sub_out_;                 // substepping: one substep's projection
  Projection::ContactEnergy split_contact_;  // substepping: the contacts' energy over the substeps taken
  double split_kinetic_loss_ = 0;            // substepping: the substeps' Projection::kinetic_loss
  double whole_h_ = 0;                       // substepping: the whole step's length (the contacts' springs)
  std::vector<Vec3> sub_x1_, sub_v1_;  // substepping: the state a substep applies
};

std::unique_ptr<StepIntegrator> make_coupled(const IntegratorConfig& config) {
  return std::make_unique<CoupledIntegrator>(config);
}

constexpr CoupledSolver kCoupledSolvers[] = {CoupledSolver::dense, CoupledSolver::ldlt, CoupledSolver::cg};

}  // namespace

const IntegratorInfo coupled_implicit_integrator = {
    IntegratorType::coupled_implicit, "coupled_implicit",
    "Eq. 13 linearised (Baraff-Witkin): one global linear solve (sweeps: hybrid_implicit, neighbours sweep)",
    kCoupledSolvers, kEveryWarmStart, make_coupled};

}  // namespace qbond
