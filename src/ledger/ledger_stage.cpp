#include "ledger/ledger_stage.hpp"

#include "ledger/step_work.hpp"

namespace qbond {

void LedgerStage::begin(const LedgerHints& hints, int threads) {
  hints_ = hints;
  threads_ = threads;
  split_ = false;
  anchors_ = damping_ = numerical_damping_ = 0;
}

void LedgerStage::charge(const Model& model, const State& start, const Adjacency& adj, const Projection& p,
                         std::span<const Vec3> x1, std::span<const Vec3> v1, const std::vector<Vec3>& f_ext,
                         double h) {
  // Loads are linear in Δx: the whole step's charge is exact for them.
  const StepWork w = step_work(model, start, adj, p, {x1, v1}, f_ext, h, hints_, threads_);
  anchors_ += w.anchors;
  damping_ += w.damping;
  numerical_damping_ += numerical_damping(w, p);
  split_ = true;
}

double LedgerStage::charge_step(const Model& model, State& s, const Adjacency& adj, const Projection& p,
                                const AppliedState& next, const std::vector<Vec3>& f_ext, double h) {
  const StepWork w = step_work(model, s, adj, p, next, f_ext, h, hints_, threads_);
  EnergyLedger& l = s.energy;
  l.work_loads += w.loads;
  l.work_anchors += split_ ? anchors_ : w.anchors;
  l.dissipated_damping += split_ ? damping_ : w.damping;
  l.numerical_damping += split_ ? numerical_damping_ : numerical_damping(w, p);
  if (p.contact.charged) {
    l.dissipated_contact += p.contact.dissipated;
    l.contact_stored = p.contact.stored;
  }
  return w.bonds_after;
}

}  // namespace qbond
