#pragma once
// The stages of a step, in the order Simulation::step runs them (docs/architecture.md, "One
// step"). Each is a free function of the model (const), the state and the step's scratch
// (step_scratch.hpp), plus the few settings it reads; each says what it reads and writes.
#include <memory>
#include <span>

#include "qbond/simulation/simulation.hpp"
#include "simulation/step_scratch.hpp"

namespace qbond::stage {

// Gathers the external force of the step: gravity, loads and the forces queued for it.
// Reads model (mass, gravity, loads), k.f_user. Writes k.f_ext, or, when the step advances in
// place and gravity is the only force, sets k.gravity_alone and leaves k.f_ext as it was.
void gather_forces(const Model& model, const StepIntegrator& integrator, bool in_place, StepScratch& k);

// Projects the step, {dx, dv} from the state, or advances it in place into k.next.
// Reads model, state, k.f_ext (or gravity alone). Writes k.ctx, k.projection (or k.next and its
// check), k.in_place; starts k.ledger and hands it to the integrator when the ledger is on.
void integrate(const Model& model, const State& state, StepIntegrator& integrator, double h, double max_speed,
               bool ledger_on, bool in_place, StepScratch& k);

// Keeps the state before the step, for a rollback: its small fields, and its bonds when a
// heuristic may edit them (with_bonds). Writes k.last_good.
void save_last_good(State& state, bool with_bonds, StepScratch& k);

// Energy restoration's first half: the ledger and the energy before the step.
// Reads model, state. Writes k.books, k.e_start.
void open_books(const Model& model, const State& state, int threads, StepScratch& k);

// Runs the heuristics in order on the projected end-of-step state.
// Reads k.ctx, k.projection. Writes k.events, k.dv_forces, k.projection (contacts), the state's
// bonds and energy ledger (fracture, plasticity, formation); drops a carry-over the bond edits
// void.
void run_heuristics(const Model& model, State& state, std::span<const std::unique_ptr<Heuristic>> heuristics,
                    int threads, StepScratch& k);

// A bond whose law breaks it (the cohesive law's failure stretch s_f) and whose projected stretch
// r - L reached it breaks, whatever the heuristics: reason `failure`, its stored energy (the
// fracture energy G) charged as dissipated. Runs when an alive bond's law can fail
// (k.bonds_can_fail). Reads model, state, k.projection, k.ctx. Writes the state's bonds and
// energy ledger, k.events, k.failed.
void break_failed_bonds(const Model& model, State& state, int threads, StepScratch& k);
// The blow-up check: nothing non-finite, no free quanta faster than max_speed.
// Reads model, state, k.projection, k.ctx. Writes k.next (x + dx, v + dv, the prescribed quanta
// placed) unless the integrate stage advanced in place. Returns a blow-up report or ok.
StepReport check(const Model& model, const State& state, double max_speed, int threads, StepScratch& k);

// The energy ledger: the work of loads and anchors and the dampers' dissipation over the step.
// Reads model, state (before the step), k.projection, k.next, k.f_ext. Writes state.energy,
// k.bonds_after.
void charge_ledger(const Model& model, State& state, StepScratch& k);

// The energy guard, without heuristics: the step as charged, from E0 to E1 = K1 + U1 + G1,
// against E0 + loads' and anchors' work - dampers' dissipation. A step above that by more than
// round-off and the solve's tolerance made energy; an integrator that can takes it again in
// substeps. Reads model, state, k.next, k.bonds_after, k.guard_books. Writes k.quanta_after; when
// it retakes, state.energy (back to k.guard_books) and what integrate writes. Returns whether it
// retook the step (then check and charge_ledger run again).
bool retake_gaining_step(const Model& model, State& state, StepIntegrator& integrator, double h,
                         const BlowupLimits& limits, StepScratch& k);

// The energy guard with heuristics: the integrator's own projection against its own books
// (energy_guard.hpp), before the heuristics edit it; what they add or take is theirs. Reads
// model, state, k.f_ext, k.projection. Retakes the step in substeps (integrate) when it gains.
void retake_gaining_projection(const Model& model, const State& state, StepIntegrator& integrator, double h,
                               double max_speed, StepScratch& k);

// Applies the step: x, v and the carry-over from k.next and k.projection, time and step index.
// Writes state (x, v, carry, time, step); k.next and k.projection receive the values before the
// step (a rollback reads them); clears the queued forces.
void apply(State& state, StepScratch& k);

// Energy restoration's second half: scales the internal velocities so that E(end) is E(start)
// plus the step's work less its dissipation. Reads k.books, k.e_start, state.energy. Writes state.v.
void restore_energy(const Model& model, State& state, int threads, StepScratch& k);

// The energy checks: kinetic plus bond energy within limits.energy_growth times what the system
// could have gained (a runaway), and E(t) - E(0) beyond the external work, recorded in `gain` and
// past limits.energy_gain reported (a stop with limits.stop_on_energy_gain). Reads model, state,
// k.bonds_after, k.quanta_after (unless `restored`), k.f_ext. Writes gain, k.guard_start.
// Returns a report or ok.
StepReport check_energy(const Model& model, const State& state, const BlowupLimits& limits, bool restored,
                        int threads, EnergyGain& gain, StepScratch& k);

// E(t) − E(0) beyond the external work, `g`, recorded in `gain` (its largest, relative to
// `available`, what the system could hold, and the first step past limits.energy_gain); past it
// with limits.stop_on_energy_gain, a blow-up report naming `step` and `time` (its quanta unset).
StepReport record_gain(double g, double available, std::uint64_t step, double time, const BlowupLimits& limits,
                       EnergyGain& gain);

// Hands the applied step to the observers, in order. Reads model, state, k.ctx.
void observe(const Model& model, const State& state, std::span<Observer* const> observers, const StepScratch& k);

// Puts back the state save_last_good kept; `applied`: the apply stage ran, the values before the
// step are in k.next and k.projection. Clears k.events. Returns the report, saying so.
StepReport roll_back(StepReport r, State& state, bool applied, StepScratch& k);

}  // namespace qbond::stage
