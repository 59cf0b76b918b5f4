#include "simulation/stages.hpp"

namespace qbond::stage {

void run_heuristics(const Model& model, State& state, std::span<const std::unique_ptr<Heuristic>> heuristics,
                    int threads, StepScratch& k) {
  k.events.clear();
  if (heuristics.empty()) return;
  k.dv_forces = k.projection.dv;
  const HeuristicContext hc{k.ctx, k.adjacency(model, state), threads, k.events, k.dv_forces, k.counted};
  for (const auto& h : heuristics) h->apply(model, state, k.projection, hc);
  if (k.projection.bonds_edited) drop_after_bond_edit(k.projection.carry);
}

}  // namespace qbond::stage
