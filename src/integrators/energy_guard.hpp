#pragma once
// The energy balance of a projected step, for integrators that must not create energy (the
// linearised backward-Euler step of coupled_implicit: docs/integrators.md, "No energy gain").
// A step from E₀ = K₀ + U₀ that applies (x + Δx, v + Δv) creates
//
//     gain = (K₁ − K₀) + (U₁ − U₀) − Σ_free f_ext · Δx − W_anchors,
//
// K the free quanta's kinetic energy, U the bonds' energy, f_ext the step's external forces
// (gravity and loads, constant over the step: their work is exact) and W_anchors the work moving
// prescribed quanta do through their bonds (the energy ledger's trapezoid rule, step_work.hpp).
// Each term is formed as a difference per quanta or bond, so that round-off is relative to the
// energies that move, not to a large total.
#include <cmath>
#include <vector>

#include "qbond/integrators/integrators.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

/// Whether the contacts the implicit step solves (obstacles', quanta pairs') have friction.
bool solved_contacts_rub(const Model& model);

/// The gain a step's solved contacts with friction may show without being retaken [J]: their
/// springs' energy at the step's start and end and what they took. A sticking contact's spring is
/// anchored at its step's start, so the step's balance moves by up to those energies, and halves
/// would only let it creep twice as far; a step that gains more than its contacts hold or take
/// (an impact at 1/120 s on the trampoline: 0.26 J against their 0.03 J) is retaken.
inline double friction_allowance(const Projection::ContactEnergy& c, bool rubs) {
  return rubs && c.charged ? c.stored_start + c.stored + c.dissipated : 0.0;
}

struct StepEnergyBalance {
  double gain = 0;       // energy the step creates beyond the work done on it [J]
  double scale = 0;      // Σ of the magnitudes of its terms, the size of its round-off [J]
  double allowance = 0;  // the gain its contacts' friction may show (friction_allowance) [J]
  // Whether the step creates energy beyond `relative` times its terms' size and the allowance.
  bool gains(double relative) const { return gain > relative * scale + allowance; }
  // Counts the work of the contacts solved in the step as done on it: their springs and dampers
  // are the ledger's contact columns, what is left is the bonds' and gravity's balance. `rubs`:
  // the contacts have friction.
  void credit_contacts(const Projection::ContactEnergy& c, bool rubs) {
    if (!c.charged) return;
    gain -= c.work;
    scale += std::abs(c.work);
    allowance = friction_allowance(c, rubs);
  }
};

class EnergyGuard {
 public:
  // The balance of the projection `p` of a step of length h from `state` (f_ext empty: gravity
  // alone, StepIntegrator::forms_gravity). Two passes over the quanta and one over the bonds, and
  // with moving prescribed quanta one more over their bonds. The same bits for any thread count.
  StepEnergyBalance balance(const Model& model, const State& state, const Adjacency& adj,
                            const std::vector<Vec3>& f_ext, const Projection& p, double h,
                            const LedgerHints& hints, int threads);

 private:
  std::vector<Vec3> x1_, v1_, f_;  // x + Δx, v + Δv; f_ext formed when it is empty (anchors only)
};

}  // namespace qbond
