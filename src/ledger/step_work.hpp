#pragma once
// The work one step does on the energy ledger's accounts, from the step's start state and its
// projection: what the ledger stage charges for a step, or for each substep of a step an integrator
// took in substeps (ledger_stage.hpp), so that the ledger stays exact there too.
#include <vector>

#include "ledger/energy_sums.hpp"
#include "qbond/integrators/integrators.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

struct StepWork {
  double loads = 0;    // work of the loads and user forces on free quanta [J]
  double anchors = 0;  // work the prescribed quanta do on the structure through their bonds [J]
  double damping = 0;  // energy the dampers take out [J]
  double bonds_after = 0;  // the bonds' energy at x + Δx (BondStepSums::energy_after) [J]
  // The bonds' share of backward Euler's numerical damping (hints.backward_euler; else 0):
  // BondStepSums::step_loss [J].
  double bonds_loss = 0;
};

// Backward Euler's numerical damping of a step (docs/integrators.md): the bonds' share
// (StepWork::bonds_loss) and the integrator's kinetic share, ½ Σ Δv·(m Δv − J) (Projection::kinetic_loss).
inline double numerical_damping(const StepWork& w, const Projection& p) { return w.bonds_loss + p.kinetic_loss; }

StepWork step_work(const Model& m, const State& s, const Adjacency& adj, const Projection& p,
                   const AppliedState& a, const std::vector<Vec3>& f_ext, double h, const LedgerHints& hints,
                   int threads);

}  // namespace qbond
