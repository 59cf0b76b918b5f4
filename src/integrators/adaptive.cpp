#include "qbond/integrators/adaptive.hpp"

#include <algorithm>
#include <cmath>

#include "qbond/analysis/analysis.hpp"

namespace qbond {

double step_error(const Model& model, const State& state, const Projection& p, double h) {
  double e = 0;
  for (std::size_t i = 0; i < model.num_quanta(); ++i) {
    if (model.is_kinematic(static_cast<Index>(i))) continue;
    const double ei = (p.dx[i] - h * (state.v[i] + 0.5 * p.dv[i])).norm();
    e = std::max(e, std::isfinite(ei) ? ei : HUGE_VAL);
  }
  return e;
}

AdaptiveReport adaptive_step(Simulation& sim, const AdaptiveConfig& cfg, double t_end, const std::function<void()>& forces) {
  World& w = sim.world();
  const double max_step = cfg.max_step > 0 ? cfg.max_step : HUGE_VAL;
  const State saved = w.state;  // to undo a step the energy check or a blow-up rejects
  const double numerical0 = energy_budget(w.model, w.state).dissipated_numerical;
  AdaptiveReport rep;
  double h = std::clamp(sim.timestep(), cfg.min_step, max_step);
  for (;;) {
    const double remaining = t_end - w.state.time;
    const bool last = h >= remaining;
    const double step = last ? remaining : h;
    const bool at_min = step <= cfg.min_step;
    sim.set_timestep(step);
    if (forces) {
      sim.clear_forces();
      forces();
    }
    sim.begin_step();
    const double e = step_error(w.model, w.state, sim.projection(), step);
    if (e > cfg.error && !at_min) {  // rejected before anything changed: no undo needed
      ++rep.rejected;
      h = std::max(cfg.min_step, step * std::clamp(cfg.safety * std::sqrt(cfg.error / e), 0.2, 0.9));
      continue;
    }
    rep.step = sim.end_step();
    bool undo = rep.step.status != StepReport::Status::ok;
    if (!undo) {  // one energy pass gives both the drift and its scale
      const EnergyBudget b = energy_budget(w.model, w.state);
      const double scale = std::max(std::abs(b.initial_total), std::abs(b.now.kinetic) + std::abs(b.now.bonds));
      undo = std::abs(b.dissipated_numerical - numerical0) > cfg.energy * scale * step / cfg.horizon;
    }
    if (undo && !at_min) {
      w.state = saved;
      ++rep.rejected;
      h = std::max(cfg.min_step, 0.25 * step);
      continue;
    }
    if (last) w.state.time = t_end;  // t + (t_end − t) may miss t_end by an ulp
    rep.h = step;
    rep.error = e;
    // No growth right after a refusal: the step that just failed is the best evidence there is.
    const double grow = std::min(rep.rejected > 0 ? 1.0 : 2.0,
                                 e > 0 ? std::clamp(cfg.safety * std::sqrt(cfg.error / e), 0.2, 2.0) : 2.0);
    // The proposal grows from the step the error allowed, not from a short last step.
    sim.set_timestep(std::clamp((last && step < h ? h : step) * grow, cfg.min_step, max_step));
    return rep;
  }
}

}  // namespace qbond
