#pragma once
// What the stages of a step (stages.hpp) hand each other besides the model and the state, and
// their buffers: private to the step, never part of the contract.
#include <algorithm>
#include <cstdint>
#include <vector>

#include "integrators/advance.hpp"
#include "integrators/energy_guard.hpp"
#include "ledger/ledger_stage.hpp"
#include "qbond/analysis/analysis.hpp"
#include "qbond/heuristics/heuristics.hpp"
#include "qbond/integrators/integrators.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

struct StepScratch {
  std::vector<Vec3> f_ext;      // external force of this step [N] (n)
  std::vector<Vec3> f_user;     // one-step forces queued by Simulation::add_force [N] (n)
  bool forces_queued = false;   // f_user holds a force (else it is all zero)
  bool gravity_alone = false;   // f_ext not gathered: the integrator forms gravity (gather_forces)
  bool in_place = false;        // the integrate stage advanced the step in place: `next` is written
  StepContext ctx;              // this step's length, start time and index
  Projection projection;        // the step's {dx, dv} and carry-over
  Advanced next;                // the state the step applies, x + dx and v + dv, and its check
  PrescribedAt prescribed;      // where the check stage places the prescribed quanta
  std::vector<BondEvent> events;    // topology changes the heuristics and failures made this step
  std::vector<Vec3> dv_forces;      // the projection's dv before the heuristics [m/s] (n)
  std::vector<std::uint8_t> counted;  // HeuristicContext::counted (empty: every quanta)
  LedgerStage ledger;           // with the substeps of a step taken in substeps
  double bonds_after = 0;       // the bonds' energy after the step, from the ledger [J]
  EnergyLedger books;           // the ledger before the step (energy restoration)
  double e_start = 0;           // E before the step (energy restoration) [J]
  // The energy guard (guard_energy.cpp): E at the end of the last step, for the state of
  // `guard_step` (the next step's start), and the ledger before this step's charges.
  Energies guard_start;
  std::uint64_t guard_step = ~std::uint64_t{0};
  double guard_time = 0;
  EnergyLedger guard_books;
  Energies quanta_after;        // kinetic and gravity energy of `next` (the guard's, reused by check_energy)
  bool quanta_after_valid = false;
  EnergyGuard guard;            // retake_gaining_projection's
  State last_good;              // the state before the step, for a rollback (save_last_good)
  bool last_good_has_bonds = false;  // whether last_good holds the bond arrays too
  Adjacency adj;                // of the alive bonds, rebuilt when the topology changes
  std::vector<std::uint8_t> failed;  // per bond: reached its law's failure stretch (break_failed_bonds)
  bool can_fail = false;             // an alive bond's law can fail, for the topology of `fail_version`
  std::uint64_t fail_version = ~std::uint64_t{0};

  // The adjacency of the state's alive bonds, rebuilt only when its topology version changed.
  const Adjacency& adjacency(const Model& model, const State& state) {
    if (adj.version != state.topology_version()) build_adjacency(model, state, adj);
    return adj;
  }
  // Whether an alive bond follows a law with a failure stretch (then break_failed_bonds runs),
  // found again only when the topology version changed.
  bool leave_failures = false;  // Simulation::leave_failures_to_caller
  bool bonds_can_fail(const State& state) {
    if (leave_failures) return false;
    if (fail_version != state.topology_version()) {
      const Bonds& b = state.bonds;
      can_fail = false;
      for (std::size_t i = 0; i < b.size() && !can_fail; ++i) can_fail = b.alive[i] && law_breaks(b.law[i]);
      fail_version = state.topology_version();
    }
    return can_fail;
  }
  // Drops the forces queued for the next step.
  void clear_forces() {
    if (!forces_queued) return;  // most steps: nothing to clear, no pass over the quanta
    std::fill(f_user.begin(), f_user.end(), Vec3::Zero());
    forces_queued = false;
  }
};

}  // namespace qbond
