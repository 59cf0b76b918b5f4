#include <cmath>
#include <sstream>

#include "core/parallel.hpp"
#include "qbond/analysis/analysis.hpp"
#include "simulation/stages.hpp"

namespace qbond::stage {

StepReport check_energy(const Model& m, const State& s, const BlowupLimits& limits, int threads,
                        const StepScratch& k) {
  StepReport r;
  const EnergyLedger& l = s.energy;
  // The bonds' energy the ledger summed at the positions this step applied (the same pass as
  // the dampers' work), but for round-off where a prescribed quanta landed on its path instead.
  Energies e = quanta_energies(m, s, threads);
  e.bonds = k.bonds_after;
  // External forces can also give energy before they have done measurable work (a step from
  // rest changes velocity before position): allow the kinetic energy their impulse over the
  // elapsed time would give each free quanta, Σ |f_ext t|² / (2 m).
  const double t = s.time - l.initial_time;
  const double impulse = deterministic_sum(m.num_quanta(), threads, [&](std::size_t i) {
    return 0.5 * m.inv_mass[i] * (t * k.f_ext[i]).squaredNorm();
  });
  const double available = (l.initial_total - l.initial_gravity) + std::abs(e.gravity - l.initial_gravity) +
                           std::abs(l.work_loads) + std::abs(l.work_anchors) + impulse;
  const double held = e.kinetic + e.bonds;
  if (held <= limits.energy_growth * available + limits.energy_floor) return r;
  const auto [speed, who] = max_speed(m, s);
  std::ostringstream msg;
  msg.precision(6);
  msg << "blow-up at step " << s.step << " (t = " << s.time << " s): energy runaway, kinetic + bond energy "
      << held << " J exceeds " << limits.energy_growth << " x the " << available
      << " J the system could have gained; fastest quanta " << m.quanta_id[who] << " at " << speed << " m/s";
  r.status = StepReport::Status::blowup;
  r.message = msg.str();
  r.worst = who;
  return r;
}

}  // namespace qbond::stage
