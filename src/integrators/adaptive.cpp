#include "qbond/integrators/adaptive.hpp"

#include <algorithm>
#include <cmath>

#include "qbond/analysis/analysis.hpp"

namespace qbond {

namespace {
// Quanta i's error estimate |Δx_i − h (v_i + Δv_i/2)|, infinite when not finite.
double quanta_error(const State& state, const Projection& p, double h, std::size_t i) {
  const double e = (p.dx[i] - h * (state.v[i] + 0.5 * p.dv[i])).norm();
  return std::isfinite(e) ? e : HUGE_VAL;
}
}  // namespace

double step_error(const Model& model, const State& state, const Projection& p, double h) {
  double e = 0;
  for (std::size_t i = 0; i < model.num_quanta(); ++i)
    if (!model.is_kinematic(static_cast<Index>(i))) e = std::max(e, quanta_error(state, p, h, i));
  return e;
}

double step_error(const Model& model, const State& state, const Projection& p, double h,
                  std::span<const Index> quanta) {
  double e = 0;
  for (Index i : quanta)
    if (!model.is_kinematic(i)) e = std::max(e, quanta_error(state, p, h, i));
  return e;
}

AdaptiveController::AdaptiveController(const AdaptiveConfig& config, double proposal)
    : cfg_(config),
      max_step_(config.max_step > 0 ? config.max_step : HUGE_VAL),
      h_(std::clamp(proposal, config.min_step, max_step_)) {}

AdaptiveController::Try AdaptiveController::next_try(double t, double t_end) const {
  const double remaining = t_end - t;
  Try r;
  // A try within a billionth of the end reaches it: no sliver of a step is left over.
  r.last = h_ * (1 + 1e-9) >= remaining;
  r.step = r.last ? remaining : h_;
  r.at_min = r.step <= cfg_.min_step;
  return r;
}

bool AdaptiveController::rejects_error(const Try& t, double e) {
  if (e <= cfg_.error || t.at_min) return false;
  ++rejected_;
  h_ = std::max(cfg_.min_step, t.step * std::clamp(cfg_.safety * std::sqrt(cfg_.error / e), 0.2, 0.9));
  return true;
}

bool AdaptiveController::drifts(const Try& t, double numerical_change, double scale) const {
  return std::abs(numerical_change) > cfg_.energy * scale * t.step / cfg_.horizon;
}

void AdaptiveController::reject_undone(const Try& t) {
  ++rejected_;
  h_ = std::max(cfg_.min_step, 0.25 * t.step);
}

double AdaptiveController::next_proposal(const Try& t, double e) const {
  // No growth right after a refusal: the step that just failed is the best evidence there is.
  const double grow = std::min(rejected_ > 0 ? 1.0 : 2.0,
                               e > 0 ? std::clamp(cfg_.safety * std::sqrt(cfg_.error / e), 0.2, 2.0) : 2.0);
  // The proposal grows from the step the error allowed, not from a short last step.
  return std::clamp((t.last && t.step < h_ ? h_ : t.step) * grow, cfg_.min_step, max_step_);
}

AdaptiveReport adaptive_step(Simulation& sim, const AdaptiveConfig& cfg, double t_end, const std::function<void()>& forces) {
  World& w = sim.world();
  const State saved = w.state;  // to undo a step the energy check or a blow-up rejects
  const double numerical0 = energy_budget(w.model, w.state).integrator_loss();
  AdaptiveController control(cfg, sim.timestep());
  AdaptiveReport rep;
  for (;;) {
    const AdaptiveController::Try t = control.next_try(w.state.time, t_end);
    sim.set_timestep(t.step);
    if (forces) {
      sim.clear_forces();
      forces();
    }
    sim.begin_step();
    const double e = step_error(w.model, w.state, sim.projection(), t.step);
    if (control.rejects_error(t, e)) continue;  // rejected before anything changed: no undo needed
    rep.step = sim.end_step();
    bool undo = rep.step.status != StepReport::Status::ok;
    if (!undo) {  // one energy pass gives both the drift and its scale
      const EnergyBudget b = energy_budget(w.model, w.state);
      const double scale = std::max(std::abs(b.initial_total), std::abs(b.now.kinetic) + std::abs(b.now.bonds));
      undo = control.drifts(t, b.integrator_loss() - numerical0, scale);
    }
    if (undo && !t.at_min) {
      w.state = saved;
      control.reject_undone(t);
      continue;
    }
    if (t.last) w.state.time = t_end;  // t + (t_end − t) may miss t_end by an ulp
    rep.h = t.step;
    rep.error = e;
    rep.rejected = control.rejected();
    sim.set_timestep(control.next_proposal(t, e));
    return rep;
  }
}

}  // namespace qbond
