#include "core/parallel.hpp"
#include "heuristics/breaking.hpp"
#include "simulation/stages.hpp"

namespace qbond::stage {

void break_failed_bonds(const Model& model, State& state, int threads, StepScratch& k) {
  const Bonds& bonds = state.bonds;
  const std::size_t nb = bonds.size();
  // Which bonds failed is independent per bond (parallel); they break in bond order.
  k.failed.resize(nb);
  parallel_for(nb, bond_pass_threads(model.num_quanta(), threads), [&](std::size_t b) {
    k.failed[b] = bonds.alive[b] && law_breaks(bonds.law[b]) && past_failure(model, state, b, stretch(model, state, k.projection, b));
  });
  for (std::size_t b = 0; b < nb; ++b)
    if (k.failed[b])
      break_now(model, state, k.ctx, k.events, b, stretch(model, state, k.projection, b), BondEvent::Reason::failure);
}

}  // namespace qbond::stage
