#include "simulation/stages.hpp"

namespace qbond::stage {

void integrate(const Model& model, const State& state, StepIntegrator& integrator, double h, double max_speed,
               bool ledger_on, bool in_place, StepScratch& k) {
  const Adjacency& adj = k.adjacency(model, state);
  static const std::vector<Vec3> kGravityAlone;  // StepIntegrator::forms_gravity
  const std::vector<Vec3>& f_ext = k.gravity_alone ? kGravityAlone : k.f_ext;
  k.ctx = {.h = h, .t = state.time, .step = state.step};
  k.ledger.begin(integrator.ledger_hints(), integrator.config().threads);
  integrator.set_substep_ledger(ledger_on ? &k.ledger : nullptr);
  k.in_place = in_place;
  if (!in_place) return integrator.project(model, state, adj, f_ext, k.ctx, k.projection);
  k.next.max_speed = max_speed;
  integrator.advance(model, state, adj, f_ext, k.ctx, k.projection, k.next);
}

}  // namespace qbond::stage
