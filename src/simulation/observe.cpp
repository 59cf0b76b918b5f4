#include "simulation/stages.hpp"

namespace qbond::stage {

void observe(const Model& model, const State& state, std::span<Observer* const> observers, const StepScratch& k) {
  for (Observer* o : observers) o->observe(model, state, k.ctx);
}

}  // namespace qbond::stage
