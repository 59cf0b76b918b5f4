#include "simulation/stages.hpp"

namespace qbond::stage {

void charge_ledger(const Model& model, State& state, StepScratch& k) {
  // Before the state moves: the ledger reads the state before the step and the one it applies.
  k.bonds_after = k.ledger.charge_step(model, state, k.adjacency(model, state), k.projection, {k.next.x, k.next.v},
                                       k.f_ext, k.ctx.h);
}

}  // namespace qbond::stage
