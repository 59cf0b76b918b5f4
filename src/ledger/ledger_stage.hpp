#pragma once
// The energy ledger as an optional stage of the step (Simulation::end_step): charges each step's
// work and dissipation to State::energy from the state before the step, its projection and the
// state it applies (step_work.hpp). What it needs from the integrator is where it evaluated
// damping and tensions (LedgerHints) and, for a step taken in substeps, each substep, which the
// integrator hands over as it takes them (SubstepLedger).
#include <span>
#include <vector>

#include "integrators/advance.hpp"
#include "ledger/energy_sums.hpp"
#include "qbond/integrators/integrators.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

class LedgerStage final : public SubstepLedger {
 public:
  // Before the integrate stage: the integrator's hints and threads, and no substep yet.
  void begin(const LedgerHints& hints, int threads);
  // One substep: its anchors' and dampers' work, summed over the step's substeps.
  void charge(const Model& model, const State& start, const Adjacency& adj, const Projection& p,
              std::span<const Vec3> x1, std::span<const Vec3> v1, const std::vector<Vec3>& f_ext,
              double h) override;
  // Charges the step from `s` (the state before it) to `next` (x + dx, v + dv) to s.energy: the
  // loads' work, and the anchors' and dampers' from the whole step, or summed over its substeps
  // when the integrator took it in substeps. Returns the bonds' energy at next.x [J].
  double charge_step(const Model& model, State& s, const Adjacency& adj, const Projection& p,
                     const AppliedState& next, const std::vector<Vec3>& f_ext, double h);

 private:
  LedgerHints hints_;
  int threads_ = 1;
  bool split_ = false;  // a substep was charged
  double anchors_ = 0, damping_ = 0, numerical_damping_ = 0;  // summed over the substeps [J]
};

}  // namespace qbond
