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
};

// Loads are constant over the step (their work is exact); anchors' bond forces use the trapezoid
// rule, or the discrete gradient the integrator applied (hints.discrete_gradient); dampers are
// charged at the velocity v + θ Δv along the bond d + φ Δd at which the integrator evaluated them
// (hints.damping_theta, damping_direction_theta).
// `adj` is the adjacency of the alive bonds; `a` the state the step applies (x + Δx, v + Δv).
StepWork step_work(const Model& m, const State& s, const Adjacency& adj, const Projection& p,
                   const AppliedState& a, const std::vector<Vec3>& f_ext, double h, const LedgerHints& hints,
                   int threads);

}  // namespace qbond
