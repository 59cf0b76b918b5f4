#include <array>
#include <cmath>

#include "core/parallel.hpp"
#include "simulation/stages.hpp"

namespace qbond::stage {

namespace {
// A step that ends with more energy than its books allow by more than this fraction of its
// energies' magnitudes is retaken in substeps: above the solver's own error (CG at its relative
// tolerance) and round-off.
constexpr double kStepGainTolerance = 1e-9;
}  // namespace

bool retake_gaining_step(const Model& m, State& s, StepIntegrator& integrator, double h, const BlowupLimits& limits,
                         StepScratch& k) {
  const int threads = integrator.config().threads;
  using Pair = std::array<double, 2>;
  const Pair kg = deterministic_reduce(
      m.num_quanta(), threads, Pair{0, 0},
      [&](Pair acc, std::size_t i) {
        if (m.inv_mass[i] == 0) return acc;
        acc[0] += 0.5 * m.mass[i] * k.next.v[i].squaredNorm();
        acc[1] -= m.mass[i] * m.gravity.dot(k.next.x[i]);
        return acc;
      },
      [](const Pair& a, const Pair& b) { return Pair{a[0] + b[0], a[1] + b[1]}; });
  k.quanta_after = {.kinetic = kg[0], .bonds = 0, .gravity = kg[1]};
  k.quanta_after_valid = true;
  if (!integrator.splits_gaining_steps()) return false;
  if (k.guard_step != s.step || k.guard_time != s.time) {
    k.guard_start = energies(m, s, threads);  // the first step, or the state was replaced
    k.guard_step = s.step;
    k.guard_time = s.time;
  }
  const Energies& e0 = k.guard_start;
  const EnergyLedger& l = s.energy;
  const EnergyLedger& b = k.guard_books;
  const double work = (l.work_loads - b.work_loads) + (l.work_anchors - b.work_anchors);
  const double lost = l.dissipated_damping - b.dissipated_damping;
  const double e1 = kg[0] + k.bonds_after + kg[1];
  // Contacts solved in the step: their impulses' work is theirs (their springs and dampers are
  // the ledger's contact columns), what is left is the bonds' and gravity's balance.
  const double contact = k.projection.contact.charged ? k.projection.contact.work : 0.0;
  const double gain = e1 - e0.total() - work - contact + lost;
  const double scale = e0.kinetic + e0.bonds + kg[0] + k.bonds_after + std::abs(kg[1] - e0.gravity) + std::abs(work) +
                       std::abs(contact) + std::abs(lost);
  const double allowance = friction_allowance(k.projection.contact, solved_contacts_rub(m));
  if (!(gain > kStepGainTolerance * scale + limits.energy_floor + allowance)) return false;
  s.energy = b;
  k.quanta_after_valid = false;
  integrator.split_next_step();
  integrate(m, s, integrator, h, limits.max_speed, true, false, k);
  return true;
}

void retake_gaining_projection(const Model& m, const State& s, StepIntegrator& integrator, double h, double max_speed,
                               StepScratch& k) {
  if (!integrator.splits_gaining_steps()) return;
  StepEnergyBalance b = k.guard.balance(m, s, k.adjacency(m, s), k.f_ext, k.projection, h,
                                        integrator.ledger_hints(), integrator.config().threads);
  b.credit_contacts(k.projection.contact, solved_contacts_rub(m));  // as retake_gaining_step
  if (!b.gains(kStepGainTolerance)) return;
  integrator.split_next_step();
  integrate(m, s, integrator, h, max_speed, true, false, k);
}

}  // namespace qbond::stage
