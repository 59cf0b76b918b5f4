#include <cmath>
#include <sstream>

#include "core/parallel.hpp"
#include "qbond/analysis/analysis.hpp"
#include "simulation/stages.hpp"

namespace qbond::stage {

StepReport record_gain(double g, double available, std::uint64_t step, double time, const BlowupLimits& limits,
                       EnergyGain& gain) {
  if (g > gain.largest) {
    gain.largest = g;
    gain.relative = available > 0 ? g / available : HUGE_VAL;
  }
  if (g <= limits.energy_gain * available + limits.energy_floor) return {};
  if (!gain.exceeded) {
    gain.exceeded = true;
    gain.first_step = step;
    gain.first_time = time;
  }
  if (!limits.stop_on_energy_gain) return {};
  std::ostringstream msg;
  msg.precision(6);
  msg << "energy gained at step " << step << " (t = " << time << " s): the energy exceeds its initial value plus "
      << "the external work by " << g << " J, more than " << limits.energy_gain << " x the " << available
      << " J the system could hold (limits.stop_on_energy_gain)";
  StepReport r;
  r.status = StepReport::Status::blowup;
  r.message = msg.str();
  return r;
}

StepReport check_energy(const Model& m, const State& s, const BlowupLimits& limits, bool restored, int threads,
                        EnergyGain& gain, StepScratch& k) {
  StepReport r;
  const EnergyLedger& l = s.energy;
  // The bonds' energy the ledger summed at the positions this step applied (the same pass as
  // the dampers' work), but for round-off where a prescribed quanta landed on its path instead.
  Energies e = k.quanta_after_valid && !restored ? k.quanta_after : quanta_energies(m, s, threads);
  e.bonds = k.bonds_after;
  k.guard_start = e;  // the next step's start (retake_gaining_step)
  k.guard_step = s.step;
  k.guard_time = s.time;
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
  if (held <= limits.energy_growth * available + limits.energy_floor) {
    // E(t) - E(0) beyond the loads' and anchors' work: energy the integrator (or a heuristic) made.
    r = record_gain(e.total() - l.initial_total - l.work_loads - l.work_anchors, available, s.step, s.time, limits,
                    gain);
    if (r.status != StepReport::Status::ok) r.worst = max_speed(m, s).second;
    return r;
  }
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
