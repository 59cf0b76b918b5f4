#include "simulation/stages.hpp"

namespace qbond::stage {

StepReport check(const Model& model, const State& state, double max_speed, int threads, StepScratch& k) {
  // The plain test every step passes, no free quanta too fast and nothing non-finite, with the
  // state the step will apply formed: by the integrator when it advanced in place, else here.
  if (!k.in_place) {
    k.next.max_speed = max_speed;
    apply_checked(model, state, k.projection, k.ctx.t + k.ctx.h, threads, k.prescribed, k.next);
  }
  if (k.next.ok) return {};
  const Blowup b = find_blowup(model, k.next.x, k.next.v, max_speed, k.ctx, threads);
  if (!b.found) return {};
  StepReport r;
  r.status = StepReport::Status::blowup;
  r.message = b.message + "; the world keeps the state before this step";
  r.worst = b.who;
  return r;
}

}  // namespace qbond::stage
