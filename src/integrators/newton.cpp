// The Newton-solved integrators: energy_momentum (the paper's section 5 "method of integration
// that paid attention to the total energy"), implicit_midpoint and bdf2. newton.hpp has the
// schemes and the Newton system; this file evaluates them and runs the iteration with the
// coupled integrator's linear solvers (backward_euler.hpp).
#include "integrators/newton.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include "integrators/integrator_common.hpp"
#include "integrators/ranks_link.hpp"
#include "core/parallel.hpp"

namespace qbond {

namespace {
// One bond's force on its first quanta and its Newton block.
struct BondStep {
  Vec3 f = Vec3::Zero();  // force on bond_i [N] (bond_j gets −f)
  Vec3 u = Vec3::Zero();  // direction of the blocks (the bond where the force is taken)
  double ka = 0, kb = 0;  // K̃ = ka u uᵀ + kb I ≈ ∂f/∂Δd, clamped positive semi-definite [N/m]
  double ca = 0, cb = 0;  // ∂f/∂w = ca u uᵀ + cb I [N·s/m]
};

// The exact derivatives of a bond's force on bond_i: unclamped, non-symmetric.
struct BondJacobian {
  Mat3 K = Mat3::Zero();  // ∂f/∂Δd [N/m]
  Mat3 C = Mat3::Zero();  // ∂f/∂w [N·s/m]
};

// The damper's force on bond_i for relative velocity w along unit u, and the symmetric part of
// its derivative with respect to the bond's separation (the axial damper turns with the bond:
// ∂(D (w·u) u)/∂d = D (w·u)/r (I − u uᵀ) + D u wᵀ(I − u uᵀ)/r; the second, non-symmetric term
// vanishes when w ∥ u and is left out of the Newton block).
struct Damper {
  Vec3 f;
  double transverse;  // D (w·u)/r: coefficient of (I − u uᵀ) in ∂f/∂d
};
Damper damper(const Bonds& bonds, std::size_t b, const Vec3& u, double r, const Vec3& w) {
  const double D = bonds.damping[b];
  if (bonds.damping_model[b] == DampingModel::axial) {
    const double wu = w.dot(u);
    return {D * wu * u, D * wu / r};
  }
  return {D * w, 0.0};
}

// The damper's full derivatives: ∂f/∂d (both turning terms above) and ∂f/∂w.
void damper_jacobian(const Bonds& bonds, std::size_t b, const Vec3& u, double r, const Vec3& w, Mat3& Kd,
                     Mat3& C) {
  const double D = bonds.damping[b];
  if (bonds.damping_model[b] == DampingModel::axial) {
    const Mat3 P = Mat3::Identity() - u * u.transpose();
    Kd = (D / r) * (w.dot(u) * P + u * (P * w).transpose());
    C = D * u * u.transpose();
  } else {
    Kd.setZero();
    C = D * Mat3::Identity();
  }
}

// Writes K_b's axial and transverse coefficients as ka u uᵀ + kb I, clamped at 0 when `clamp`
// (laws.hpp, stiffness_coefficients: so that A stays positive definite).
void clamp_into(double axial, double transverse, bool clamp, BondStep& s) {
  const StiffnessCoefficients k = stiffness_coefficients(axial, transverse, clamp);
  s.ka = k.ka();
  s.kb = k.kb();
}

// The laws other than linear, out of line: inlined, their calls (exp, log1p, ...) made the
// compiler keep bond_step's working values in memory on the linear bonds' path too.
[[gnu::noinline]] MeanTension curved_mean_tension(const Bonds& bonds, const std::vector<LawShape>& shapes,
                                                  std::size_t b, double r0, double r1, double L) {
  return mean_tension(bonds.law[b], r0, r1, L, bonds.law_args(shapes, b));
}
[[gnu::noinline]] LawValue curved_law_value(const Bonds& bonds, const std::vector<LawShape>& shapes,
                                            std::size_t b, double r, double L) {
  return evaluate_law(bonds.law[b], r, L, bonds.law_args(shapes, b));
}

// Bond b (rest length L) whose separation d = x_j − x_i starts at d0 and changes by dd over the
// step, its dampers seeing the relative velocity w (at the scheme's θ); `clamp` as NewtonStep's.
// With `exact`, also the full derivatives (zero for a bond through zero length, like f).
// Always inlined into newton_bonds' loop: called, it took d0, dd, w and its result through
// memory and spilled its working values, a few percent of energy_momentum's whole step.
[[gnu::always_inline]] inline BondStep bond_step(const Model& model, const Bonds& bonds, std::size_t b,
                                                 double L, NewtonScheme scheme, const Vec3& d0,
                                                 const Vec3& dd, const Vec3& w, bool clamp,
                                                 BondJacobian* exact) {
  BondStep s;
  if (exact) *exact = {};
  const bool axial_damper = bonds.damping_model[b] == DampingModel::axial;
  (axial_damper ? s.ca : s.cb) = bonds.damping[b];
  if (scheme == NewtonScheme::energy_momentum) {
    // Discrete gradient (Gonzalez 1996; Simo & Tarnow 1992): f = T̄ d_mid / r̄ with
    // T̄ = (U(r₁) − U(r₀))/(r₁ − r₀), r̄ = (r₀ + r₁)/2. Since Δd · d_mid = (r₁² − r₀²)/2 = (r₁ − r₀) r̄,
    // the bond's work f · Δd is exactly U(r₁) − U(r₀); f ∥ d_mid, the lever arm of the midpoint
    // positions, so the pair exerts no torque about the midpoint configuration: momentum and
    // angular momentum are kept exactly.
    const Vec3 dm = d0 + 0.5 * dd, d1 = d0 + dd;
    const double r0 = d0.norm(), r1 = d1.norm(), rm = dm.norm(), rbar = 0.5 * (r0 + r1);
    if (!(rm > 0 && rbar > 0)) return s;  // a bond through zero length has no direction
    s.u = dm / rm;
    const MeanTension mt = bonds.law[b] == Law::linear
                               ? LinearLaw::mean(r0, r1, L, {.strength = bonds.strength[b]})
                               : curved_mean_tension(bonds, model.shapes, b, r0, r1, L);
    const double phi = mt.T / rbar;
    const Damper dmp = damper(bonds, b, s.u, rm, w);
    s.f = phi * dm + dmp.f;
    // ∂f/∂Δd = φ/2 I + d_mid φ_r1 u₁ᵀ (+ the damper's turning, ∂d_mid/∂Δd = ½), with
    // φ_r1 = ∂(T̄/r̄)/∂r₁ = T̄_r1/r̄ − T̄/(2 r̄²); u₁ is taken as u (see newton.hpp).
    const double phi_r1 = mt.dT1 / rbar - mt.T / (2 * rbar * rbar);
    clamp_into(0.5 * phi + rm * phi_r1, 0.5 * (phi + dmp.transverse), clamp, s);
    if (exact) {
      damper_jacobian(bonds, b, s.u, rm, w, exact->K, exact->C);
      exact->K *= 0.5;
      exact->K.diagonal().array() += 0.5 * phi;
      if (r1 > 0) exact->K += (phi_r1 / r1) * dm * d1.transpose();  // d_mid φ_r1 u₁ᵀ
    }
    return s;
  }
  // Forces at one point of the step: the midpoint (∂d/∂Δd = ½) or the end (1).
  const double g = scheme == NewtonScheme::implicit_midpoint ? 0.5 : 1.0;
  const Vec3 d = d0 + g * dd;
  const double r = d.norm();
  if (!(r > 0)) return s;
  s.u = d / r;
  const LawValue lv = bonds.law[b] == Law::linear ? LinearLaw::eval(r, L, {.strength = bonds.strength[b]})
                                                  : curved_law_value(bonds, model.shapes, b, r, L);
  const Damper dmp = damper(bonds, b, s.u, r, w);
  s.f = lv.T * s.u + dmp.f;
  // ∂f/∂d = T' u uᵀ + (T/r)(I − u uᵀ) + the damper's turning (K_b: laws.hpp, stiffness_block).
  clamp_into(g * lv.dT, g * (lv.T / r + dmp.transverse), clamp, s);
  if (exact) {
    damper_jacobian(bonds, b, s.u, r, w, exact->K, exact->C);
    const StiffnessCoefficients k = stiffness_coefficients(lv.dT, lv.T / r, /*clamp_for_solver=*/false);
    exact->K += block_matrix(s.u, k.ka(), k.kb());
    exact->K *= g;
  }
  return s;
}
}  // namespace

void setup_newton_step(NewtonScheme scheme, const Model& model, const State& state, const Projection& kin, double h,
                       const std::vector<Vec3>* x_prev, const std::vector<Vec3>* v_prev, NewtonStep& st) {
  const std::size_t n = model.num_quanta();
  st.scheme = scheme;
  st.h = h;
  st.a.resize(n);
  st.e.assign(n, Vec3::Zero());
  const bool bdf2 = scheme == NewtonScheme::bdf2;
  assert(!bdf2 || (x_prev && v_prev && x_prev->size() == n && v_prev->size() == n));
  switch (scheme) {
    case NewtonScheme::energy_momentum:
    case NewtonScheme::implicit_midpoint: st.s = 1; st.c = 0.5 * h; st.theta = 0.5; break;
    case NewtonScheme::bdf2: st.s = 2.0 / 3; st.c = 2.0 * h / 3; st.theta = 1; break;
    case NewtonScheme::backward_euler: st.s = 1; st.c = h; st.theta = 1; break;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (model.is_kinematic(static_cast<Index>(i))) {
      st.a[i] = kin.dx[i];
      continue;
    }
    if (bdf2) {
      st.a[i] = (state.x[i] - (*x_prev)[i]) / 3 + st.c * state.v[i];
      st.e[i] = (state.v[i] - (*v_prev)[i]) / 3;
    } else {
      st.a[i] = h * state.v[i];
    }
  }
}

void newton_bonds(const Model& model, const State& state, const NewtonStep& st, const std::vector<Vec3>& y,
                  int threads, std::vector<Vec3>& force, ImplicitSystem* sys) {
  const std::size_t nb = state.bonds.size();
  force.resize(nb);
  if (sys) sys->bonds.resize(nb);
  const bool exact = sys && st.exact;
  if (sys) sys->exact.resize(exact ? nb : 0);
  const double sh = st.s * st.h;
  parallel_for(nb, bond_pass_threads(model.num_quanta(), threads), [&](std::size_t b) {
    const Index i = state.bonds.i[b], j = state.bonds.j[b];
    BondStep bs;
    BondJacobian jac;
    if (state.bonds.alive[b]) {
      const Vec3 d0 = state.x[j] - state.x[i];
      const Vec3 dd = st.dx(model, y, j) - st.dx(model, y, i);
      const Vec3 w = (state.v[j] + st.theta * y[j]) - (state.v[i] + st.theta * y[i]);
      bs = bond_step(model, state.bonds, b, state.bonds.rest[b], st.scheme, d0, dd, w, st.clamp,
                     exact ? &jac : nullptr);
    }
    if (exact) sys->exact[b] = sh * (st.c * jac.K + st.theta * jac.C);
    force[b] = bs.f;
    if (sys) {
      // B_b = s h (c K̃ + θ C): ∂Δd/∂y = c, ∂w/∂y = θ.
      sys->bonds.set(b, bs.u, sh * (st.c * bs.ka + st.theta * bs.ca), sh * (st.c * bs.kb + st.theta * bs.cb));
    }
  });
}

ResidualNorms newton_residual(const Model& model, const Bonds& bonds, const Adjacency& adj, const NewtonStep& st,
                              const std::vector<Vec3>& f_ext, const std::vector<Vec3>& force,
                              const std::vector<Vec3>& y, int threads, std::vector<Vec3>& R,
                              std::vector<double>& scale) {
  const std::size_t n = model.num_quanta();
  const double sh = st.s * st.h;
  R.resize(n);
  scale.resize(n);
  parallel_for(n, threads, [&](std::size_t q) {
    const auto i = static_cast<Index>(q);
    if (model.is_kinematic(i)) {
      R[i].setZero();
      scale[i] = 0;
      return;
    }
    Vec3 f = f_ext[i];
    double mag = f_ext[i].norm();
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
      const Index b = adj.bond[e];
      f += bonds.i[b] == i ? force[b] : Vec3(-force[b]);
      mag += force[b].norm();
    }
    const Vec3 inertia = model.mass[i] * (y[i] - st.e[i]);
    R[i] = inertia - sh * f;
    scale[i] = inertia.norm() + sh * mag;
  });
  ResidualNorms nr;
  nr.r2 = deterministic_sum(n, threads, [&](std::size_t i) { return R[i].squaredNorm(); });
  nr.ref2 = deterministic_sum(n, threads, [&](std::size_t i) { return scale[i] * scale[i]; });
  return nr;
}

namespace {

// Each Newton iteration's linear solve (CG, sweeps) stops at this relative residual, or sooner
// when the step is nearly converged (inexact Newton: the outer residual decides when to stop).
constexpr double kForcing = 1e-3;
// Halvings of a Newton step tried before the smallest is taken anyway.
constexpr int kMaxHalvings = 12;
// Restarts of a stalled step and their initial guesses y = −β v.
constexpr int kRestarts = 4;
constexpr double kRestartBeta[kRestarts] = {1, 2, 0.5, 1.5};
// Polishing a converged step (NewtonIntegrator::polish): at most this many exact corrections
// (one or two are taken: from the tolerance exact Newton reaches round-off in one).
constexpr int kPolishIterations = 3;

// energy_momentum and implicit_midpoint evaluate dampers at the midpoint velocity along the
// midpoint bond, bdf2 at the end of the step; energy_momentum's tensions are discrete gradients.
LedgerHints newton_hints(IntegratorType type) {
  const double theta = type == IntegratorType::bdf2 ? 1.0 : 0.5;
  return {.damping_theta = theta,
          .damping_direction_theta = theta,
          .discrete_gradient = type == IntegratorType::energy_momentum};
}

class NewtonIntegrator final : public StepIntegrator {
 public:
  explicit NewtonIntegrator(const IntegratorConfig& c) : StepIntegrator(c, newton_hints(c.type)) {}

  void project(const Model& model, const State& state, const Adjacency& adj,
               const std::vector<Vec3>& f_ext, const StepContext& ctx, Projection& out) override {
    const std::size_t n = model.num_quanta();
    const double h = ctx.h;
    out.resize(n);
    project_kinematic(model, state, ctx, out);
    topo_.update(model, adj);
    stats_ = {};

    NewtonScheme scheme = NewtonScheme::energy_momentum;
    if (config_.type == IntegratorType::implicit_midpoint) scheme = NewtonScheme::implicit_midpoint;
    const bool bdf2 = config_.type == IntegratorType::bdf2;
    // BDF2 reads the state one step back from its history when that is the step just before this
    // one, taken with this h; otherwise (a timestep change, another integrator's run, a fresh
    // start) it restarts with one backward-Euler step (self-starting, first order).
    const auto* history = bdf2 ? std::get_if<Bdf2History>(&state.carry) : nullptr;
    if (history && !history->precedes(n, ctx.t, h, ctx.step)) history = nullptr;
    if (bdf2) scheme = history ? NewtonScheme::bdf2 : NewtonScheme::backward_euler;
    history_ = history;
    initial_guess(config_.warm_start, model, f_ext, h, bdf2 ? no_history_ : state.carry, config_.threads, y_);
    double residual = 0;
    const bool converged = solve(model, state, adj, f_ext, scheme, out, h, residual);
    stats_.residual = residual;
    if (converged || bdf2 || ranks_) {
      // bdf2 (and its backward-Euler start) is never split: its step reads the state one whole
      // step back (Bdf2History), which a substep does not have (docs/integrators.md). Over ranks
      // the run takes an unconverged step again in halves, each a step over the ranks of its own
      // (distributed_step.cpp).
      if (!converged) ++stats_.unconverged;
      for (std::size_t i = 0; i < n; ++i) {
        if (model.is_kinematic(static_cast<Index>(i))) continue;
        out.dv[i] = y_[i];
        out.dx[i] = step_.dx(model, y_, static_cast<Index>(i));
      }
    } else {
      // Substepping fallback: a composition of energy-momentum (or midpoint) steps keeps what each
      // step keeps, so the halves, solved each from the state the one before reached, give a step
      // with the scheme's conservation properties; halves that do not converge split again, down
      // to h / 2^kNewtonSplitDepth. Kinematic rows keep the whole step's prescribed motion.
      sub_ = state;
      stats_.residual = 0;  // the largest of the substeps' from here
      const double t0 = ctx.t, t1 = ctx.t + h, tm = t0 + 0.5 * h;
      substep(model, adj, f_ext, scheme, t0, tm, ctx.step, 1);
      substep(model, adj, f_ext, scheme, tm, t1, ctx.step, 1);
      for (std::size_t i = 0; i < n; ++i) {
        if (model.is_kinematic(static_cast<Index>(i))) continue;
        out.dx[i] = sub_.x[i] - state.x[i];
        out.dv[i] = sub_.v[i] - state.v[i];
      }
    }
    if (bdf2) {
      // BDF2's carry-over is the state this step starts from, kept in State::carry (so that a
      // checkpoint holds it and a rollback restores it), with when it was.
      Bdf2History& kept = out.keep<Bdf2History>();
      kept.x.assign(state.x.begin(), state.x.end());
      kept.v.assign(state.v.begin(), state.v.end());
      kept.t = ctx.t;
      kept.h = h;
      kept.step = ctx.step;
    } else if (config_.warm_start == WarmStart::previous) {
      const std::vector<Vec3>& y = stats_.substeps > 0 ? out.dv : y_;
      out.keep<SolverGuess>().dv.assign(y.begin(), y.end());
    }
  }

 private:
  // Takes sub_ (the state at t0) to t1: one Newton solve over [t0, t1] or, when it does not
  // converge and depth < kNewtonSplitDepth, two halves. Hands each substep taken to the ledger, when on.
  void substep(const Model& model, const Adjacency& adj, const std::vector<Vec3>& f_ext, NewtonScheme scheme,
               double t0, double t1, std::uint64_t step, int depth) {
    const std::size_t n = model.num_quanta();
    const double H = t1 - t0;
    sub_out_.dx.resize(n);
    sub_out_.dv.resize(n);
    project_kinematic(model, sub_, StepContext{H, t0, step}, sub_out_);
    // A substep's initial guess: the configured one at this step length (the previous step's
    // Δv, of the whole step, is not one: zero then).
    initial_guess(config_.warm_start == WarmStart::previous ? WarmStart::zero : config_.warm_start, model,
                  f_ext, H, no_history_, config_.threads, y_);
    double residual = 0;
    const bool converged = solve(model, sub_, adj, f_ext, scheme, sub_out_, H, residual);
    if (!converged && depth < kNewtonSplitDepth) {
      const double tm = t0 + 0.5 * H;
      substep(model, adj, f_ext, scheme, t0, tm, step, depth + 1);
      substep(model, adj, f_ext, scheme, tm, t1, step, depth + 1);
      return;
    }
    ++stats_.substeps;
    if (!converged) ++stats_.unconverged;
    stats_.residual = std::max(stats_.residual, residual);
    for (std::size_t i = 0; i < n; ++i) {
      if (model.is_kinematic(static_cast<Index>(i))) continue;
      sub_out_.dv[i] = y_[i];
      sub_out_.dx[i] = step_.dx(model, y_, static_cast<Index>(i));
    }
    apply_substep(model, adj, f_ext, H, t1, sub_out_, sub_, sub_x1_, sub_v1_);
  }

  // Newton's iteration for one step of length h from `state`, starting from y_ (kinematic rows
  // set here from `kin`, which holds the prescribed motion: project_kinematic). Leaves the
  // solution (or the best iterate) in y_ and the step's map in step_; returns whether ‖R‖ reached
  // the tolerance, and the final relative residual.
  bool solve(const Model& model, const State& state, const Adjacency& adj, const std::vector<Vec3>& f_ext,
             NewtonScheme scheme, const Projection& kin, double h, double& residual) {
    const std::size_t n = model.num_quanta();
    const int threads = config_.threads;
    setup_newton_step(scheme, model, state, kin, h, history_ ? &history_->x : nullptr,
                      history_ ? &history_->v : nullptr, step_);
    // The modified matrix has the clamped, positive semi-definite blocks: CG and the 3×3 sweeps
    // need them, and the unclamped (indefinite) blocks make Newton fail more often with LDLᵀ and
    // dense elimination too (the four-quanta experiment at hω = 10: docs/integrators.md).
    step_.clamp = true;
    // Every solver starts with the modified matrix; exact Newton (sparse LU of the full
    // Jacobian) takes over when a modified iteration fails its line search or reduces ‖R‖ by
    // less than half, and the modified matrix again when an exact one fails
    // (docs/integrators.md): at hω = 100 the modified direction stalls where bonds turn by
    // radians and exact Newton converges; exact Newton from the first guess, though, often runs
    // to another of the step's several solutions (four quanta at hω = 10) or to a local minimum
    // of ‖R‖ (J singular there), which the modified direction leaves.
    step_.exact = false;
    // Kinematic rows carry their prescribed Δv through the bond evaluations.
    for (const Motion& m : model.motions)
      for (Index i : m.quanta) y_[i] = kin.dv[i];

    const double tol = config_.tolerance;
    double r = 0, ref = 0;
    auto evaluate = [&] {
      if (ranks_) ranks_->exchange(y_);  // the ghosts' rows, for their bonds to owned quanta
      newton_bonds(model, state, step_, y_, threads, force_, &sys_);
      ResidualNorms nr = newton_residual(model, state.bonds, adj, step_, f_ext, force_, y_, threads, R_, scale_);
      if (ranks_) nr = owned_norms();
      r = std::sqrt(nr.r2);
      ref = std::sqrt(nr.ref2);
      residual = ref > 0 ? r / ref : 0.0;
      return r <= tol * ref;  // also true when nothing moves or pulls (r = ref = 0)
    };
    bool done = evaluate();
    const bool first_exact = step_.exact;
    int failed = 0, restarts = 0, iterations = 0;  // line searches failed in a row; restarts taken
    double best = r;
    y_best_ = y_;
    while (!done && iterations < config_.newton_iterations) {
      solve_linear(model, state, adj, std::min(0.5, std::max(kForcing, 0.1 * tol * ref / r)), step_.exact);
      // Backtracking on ‖R‖: at large steps (bonds turning by radians per step) the full Newton
      // step of the approximate block can overshoot; halve it until the residual decreases.
      y0_ = y_;
      const double r_old = r;
      double alpha = 1;
      for (int k = 0; k < kMaxHalvings; ++k, alpha *= 0.5) {
        for (std::size_t i = 0; i < n; ++i)
          if (!model.is_kinematic(static_cast<Index>(i))) y_[i] = y0_[i] + alpha * delta_[i];
        done = evaluate();
        if (done || r < (1 - 1e-4 * alpha) * r_old) break;
      }
      if (!done && !(r < (1 - 1e-4 * alpha) * r_old)) {
        step_.exact = !step_.exact && !ranks_;  // this direction is exhausted: the other matrix from here
        ++stats_.switches;
        if (++failed == 2 && restarts < kRestarts) {
          // Both matrices stall: a local minimum of ‖R‖ with R ≠ 0 (J singular there). Start
          // again from y = −β v (the step's displacement h v (1 − β/2)), keeping the best y.
          const double beta = kRestartBeta[restarts++];
          for (std::size_t i = 0; i < n; ++i)
            if (!model.is_kinematic(static_cast<Index>(i))) y_[i] = -beta * state.v[i];
          step_.exact = first_exact;
          failed = 0;
        }
        done = evaluate();
      } else {
        failed = 0;
        // The modified matrix converges linearly; slower than halving ‖R‖ per iteration, exact
        // Newton (quadratic near the root this iteration approaches) takes over.
        if (!step_.exact && !ranks_ && r > 0.5 * r_old) {
          step_.exact = true;
          done = evaluate();
        }
      }
      if (r < best) {
        best = r;
        y_best_ = y_;
      }
      ++iterations;
    }
    stats_.iterations += iterations;
    if (!done && r > best) {  // the iteration cap reached: the best iterate found
      y_ = y_best_;
      done = evaluate();
    }
    if (done && config_.newton_polish && polishes(scheme) && !ranks_)
      polish(model, state, adj, evaluate, r, ref, residual);
    if (config_.restore_momentum &&
        (config_.solver == CoupledSolver::cg || config_.solver == CoupledSolver::sweep)) {
      // An iterative linear solve stopped early leaves a momentum error of the size of R; the
      // scheme's momentum change of each free component is exactly Σ (s h f_ext + m e) (bond
      // forces cancel in pairs), which a uniform shift restores.
      impulse_.resize(n);
      for (std::size_t i = 0; i < n; ++i)
        impulse_[i] = step_.s * f_ext[i] + (model.mass[i] / h) * step_.e[i];
      if (ranks_)
        ranks_->restore_momentum(model, impulse_, h, y_);
      else
        restore_component_momentum(model, topo_.components, impulse_, h, y_);
    }
    return done;
  }

  // The schemes whose exact step keeps both momenta (and energy_momentum's the energy): an
  // accepted step changes L by Σ x_mid × R, so a step left at the tolerance (1e-12 relative to
  // the residual's terms) drifts, most where the modified iteration converges linearly and so
  // stops just under the tolerance (four quanta at hω = 10). bdf2 and backward Euler keep nothing
  // that polishing would restore.
  static bool polishes(NewtonScheme scheme) {
    return scheme == NewtonScheme::energy_momentum || scheme == NewtonScheme::implicit_midpoint;
  }

  // IntegratorConfig::newton_polish: once the iteration has met the tolerance, exact-Newton
  // corrections take ‖R‖ to the round-off of its evaluation. Near the root exact Newton converges
  // quadratically, so from the tolerance one correction normally lands on round-off. The stop is
  // where ‖R‖ stagnates, not a tolerance: the round-off floor is not ε times the residual's terms
  // but the error of the bond forces, ε k |x| h per bond (tensions k (r − L) from positions known
  // to ε |x|, with r − L ≪ L), some 1e-15 to 1e-13 of the terms; a fixed tolerance near it is
  // often out of reach, and such steps would run to the iteration cap and be split. That floor
  // is along each bond and equal and opposite at its ends, so it exerts no
  // torque: L is then kept to the round-off of the sums and the update. Stops when a
  // correction does not halve ‖R‖ (undone if it did not lower it at all), or when one converged
  // so fast that by the quadratic rate (‖R‖ falls by q² where the last correction fell by q) the
  // next would change ‖R‖ by less than ε times its terms — which saves the confirming correction
  // on almost every step. The step is converged whatever polishing achieves: it never splits one.
  template <class Evaluate>
  void polish(const Model& model, const State& state, const Adjacency& adj, Evaluate& evaluate, double& r,
              double ref, double& residual) {
    constexpr double kEpsilon = std::numeric_limits<double>::epsilon();
    const std::size_t n = model.num_quanta();
    if (!step_.exact) {  // the exact blocks at the converged iterate
      step_.exact = true;
      evaluate();
    }
    for (int k = 0; k < kPolishIterations && r > 0; ++k) {
      solve_linear(model, state, adj, kForcing, true);
      ++stats_.polish_iterations;
      y0_ = y_;
      const double r_old = r, residual_old = residual;
      for (std::size_t i = 0; i < n; ++i)
        if (!model.is_kinematic(static_cast<Index>(i))) y_[i] = y0_[i] + delta_[i];
      evaluate();
      if (!(r < r_old)) {  // at round-off already: the iterate before
        y_ = y0_;
        r = r_old;
        residual = residual_old;
        return;
      }
      const double q = r / r_old;
      if (q > 0.5 || q * q * r <= kEpsilon * ref) return;
    }
  }

  // Over ranks: ‖R‖² and its terms' squared scale over the owned free quanta, added over the
  // ranks (the same on every rank, so every rank takes the same decisions).
  ResidualNorms owned_norms() const {
    const std::vector<std::uint8_t>& owned = ranks_->owned();
    double sums[2] = {0, 0};
    for (std::size_t i = 0; i < R_.size(); ++i)
      if (owned[i]) {
        sums[0] += R_[i].squaredNorm();
        sums[1] += scale_[i] * scale_[i];
      }
    ranks_->sum(sums);
    return {.r2 = sums[0], .ref2 = sums[1]};
  }

  // (M + Σ B_b) δ = −R: with the exact blocks (sys_.exact) by sparse LU when `exact` (and the
  // factorisation succeeds), otherwise the modified system with the configured solver (over
  // ranks: CG over the whole world's rows, the modified system alone).
  void solve_linear(const Model& model, const State& state, const Adjacency& adj, double eta, bool exact) {
    const std::size_t n = model.num_quanta();
    const int threads = config_.threads;
    assemble_blocks(model, state.bonds, adj, threads, config_.solver == CoupledSolver::sweep, sys_);
    sys_.rhs.resize(n);
    parallel_for(n, threads, [&](std::size_t i) { sys_.rhs[i] = -R_[i]; });  // kinematic rows of R are 0
    if (ranks_) {
      delta_.assign(n, Vec3::Zero());  // the ghosts' rows stay 0: evaluate brings y's
      SolveStats inner;
      ranks_->solve(model, state, adj, sys_, eta, delta_, inner);
      stats_.linear_iterations += inner.iterations;
      return;
    }
    sys_.rhs_norm = std::sqrt(deterministic_sum(n, threads, [&](std::size_t i) { return R_[i].squaredNorm(); }));
    if (exact) {
      ++stats_.exact_iterations;
      if (direct_.solve_lu(model, state, sys_, delta_)) return;
    }
    // The modified system; also where the exact Jacobian is singular (a turning point of R).
    exact_.swap(sys_.exact);  // assemble_system takes the exact blocks when there are any (exact_ is empty)
    SolveStats inner;
    switch (config_.solver) {
      case CoupledSolver::dense:
      case CoupledSolver::ldlt:
        direct_.solve(config_.solver, model, state, sys_, delta_);
        break;
      case CoupledSolver::cg:
        delta_.assign(n, Vec3::Zero());
        conjugate_gradient(model, state.bonds, sys_, eta, cg_cap(config_, topo_), threads, delta_,
                           /*y_zero=*/true, inner);
        break;
      case CoupledSolver::sweep:
        delta_.assign(n, Vec3::Zero());
        gs_.solve(adj, sys_, topo_.coloring, config_.iterations, eta, config_.chebyshev_rho, threads, delta_, inner);
        break;
    }
    stats_.linear_iterations += inner.iterations;
    exact_.swap(sys_.exact);
  }

  NewtonStep step_;
  ImplicitSystem sys_;
  TopologyCache topo_;
  std::vector<Vec3> y_, y0_, y_best_, delta_, force_, R_, impulse_;
  const Carry no_history_;
  const Bdf2History* history_ = nullptr;  // the step's BDF2 history (State::carry) while it projects
  std::vector<double> scale_;
  std::vector<Mat3> exact_;  // sys_.exact set aside while the modified system is solved
  State sub_;                // substepping: the state the substeps have reached
  Projection sub_out_;       // substepping: one substep's projection
  std::vector<Vec3> sub_x1_, sub_v1_;  // substepping: the state a substep applies
  DirectSolver direct_;
  GaussSeidel gs_;
};

std::unique_ptr<StepIntegrator> make_newton(const IntegratorConfig& config) {
  return std::make_unique<NewtonIntegrator>(config);
}

constexpr CoupledSolver kNewtonSolvers[] = {CoupledSolver::dense, CoupledSolver::ldlt, CoupledSolver::cg,
                                            CoupledSolver::sweep};
// A Newton integrator's substeps have no previous steps of their length to extrapolate from...
constexpr WarmStart kNewtonStarts[] = {WarmStart::zero, WarmStart::external, WarmStart::previous,
                                       WarmStart::automatic};
// ... and bdf2's carry-over is the previous state, not a previous Δv.
constexpr WarmStart kBdf2Starts[] = {WarmStart::zero, WarmStart::external, WarmStart::automatic};

}  // namespace

const IntegratorInfo energy_momentum_integrator = {
    IntegratorType::energy_momentum, "energy_momentum",
    "discrete gradient: keeps energy and both momenta at any step; Newton-solved", kNewtonSolvers, kNewtonStarts,
    make_newton};
const IntegratorInfo implicit_midpoint_integrator = {IntegratorType::implicit_midpoint, "implicit_midpoint",
                                                     "forces at the step's midpoint; Newton-solved, second order",
                                                     kNewtonSolvers, kNewtonStarts, make_newton};
const IntegratorInfo bdf2_integrator = {
    IntegratorType::bdf2, "bdf2", "second-order backward differentiation; Newton-solved, first step backward Euler",
    kNewtonSolvers, kBdf2Starts, make_newton};

}  // namespace qbond
