#include "integrators/energy_restore.hpp"
#include "qbond/analysis/analysis.hpp"
#include "simulation/stages.hpp"

namespace qbond::stage {

void open_books(const Model& model, const State& state, int threads, StepScratch& k) {
  k.books = state.energy;  // the step's work and dissipation are what the ledger adds
  k.e_start = energies(model, state, threads).total();
}

void restore_energy(const Model& m, State& s, int threads, StepScratch& k) {
  // E(end) should be E(start) + work − dissipation (contacts' included, and the energy their
  // springs took up); what is missing the integrator removed.
  const EnergyLedger& l = s.energy;
  const EnergyLedger& books = k.books;
  const double target = k.e_start + (l.work_loads - books.work_loads) + (l.work_anchors - books.work_anchors) -
                        (l.dissipated_damping - books.dissipated_damping) -
                        (l.dissipated_heuristics - books.dissipated_heuristics) -
                        (l.dissipated_contact - books.dissipated_contact) - (l.contact_stored - books.contact_stored);
  const double e_end = energies(m, s, threads).total();
  scale_internal_velocities(m, k.adjacency(m, s), s, target - e_end);
  // The integrator's numerical damping is given back with the rest of what it removed.
  s.energy.numerical_damping = books.numerical_damping;
}

}  // namespace qbond::stage
