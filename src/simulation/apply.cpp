#include "simulation/stages.hpp"

namespace qbond::stage {

void apply(State& s, StepScratch& k) {
  s.x.swap(k.next.x);  // x + Δx and v + Δv (the prescribed quanta placed), from check
  s.v.swap(k.next.v);
  s.time = k.ctx.t + k.ctx.h;
  s.step = k.ctx.step + 1;
  s.carry.swap(k.projection.carry);
  k.clear_forces();
}

}  // namespace qbond::stage
