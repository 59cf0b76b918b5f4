#include "integrators/energy_guard.hpp"

#include <array>
#include <cmath>

#include "core/parallel.hpp"
#include "integrators/integrator_common.hpp"
#include "ledger/energy_sums.hpp"
#include "ledger/step_work.hpp"

namespace qbond {

StepEnergyBalance EnergyGuard::balance(const Model& model, const State& state, const Adjacency& adj,
                                       const std::vector<Vec3>& f_ext, const Projection& p, double h,
                                       const LedgerHints& hints, int threads) {
  const std::size_t n = model.num_quanta();
  // Per free quanta: ½ m (|v + Δv|² − |v|²) = ½ m (2v + Δv)·Δv, less the external work f·Δx; and
  // the magnitudes of both.
  using Pair = std::array<double, 2>;
  auto fold = [&](Pair acc, std::size_t q) {
    const auto i = static_cast<Index>(q);
    if (model.is_kinematic(i)) return acc;
    const Vec3& v = state.v[q];
    const Vec3& dv = p.dv[q];
    const double kinetic = 0.5 * model.mass[q] * (2 * v + dv).dot(dv);
    const double work = external_force(model, f_ext, i).dot(p.dx[q]);
    acc[0] += kinetic - work;
    acc[1] += 0.5 * model.mass[q] * (v.squaredNorm() + (v + dv).squaredNorm()) + std::abs(work);
    return acc;
  };
  const Pair quanta = deterministic_reduce(n, threads, Pair{0, 0}, fold,
                                           [](const Pair& a, const Pair& b) { return Pair{a[0] + b[0], a[1] + b[1]}; });
  const BondEnergyChange bonds = bond_energy_change(model, state, p.dx, threads);
  StepEnergyBalance out{quanta[0] + bonds.change, quanta[1] + bonds.scale};
  // Prescribed quanta that move this step work on the structure through their bonds (anchors
  // that stay put do none): charged as the energy ledger charges them.
  bool moving = false;
  for (const Motion& motion : model.motions)
    for (Index q : motion.quanta) moving = moving || p.dx[q] != Vec3::Zero();
  if (moving) {
    x1_.resize(n);
    v1_.resize(n);
    parallel_for(n, threads, [&](std::size_t i) {
      x1_[i] = state.x[i] + p.dx[i];
      v1_[i] = state.v[i] + p.dv[i];
    });
    if (f_ext.empty()) {
      f_.resize(n);
      parallel_for(n, threads, [&](std::size_t i) { f_[i] = model.mass[i] * model.gravity; });
    }
    const StepWork w = step_work(model, state, adj, p, {x1_, v1_}, f_ext.empty() ? f_ : f_ext, h, hints, threads);
    out.gain -= w.anchors;
    out.scale += std::abs(w.anchors);
  }
  return out;
}

bool solved_contacts_rub(const Model& m) {
  auto rubs = [](const ContactMaterial& c) { return c.friction > 0 || c.static_coefficient() > 0; };
  bool friction = m.quanta_contact.radius > 0 && rubs(m.quanta_contact.material);
  for (const Obstacle& o : m.obstacles) friction = friction || rubs(o.material);
  return friction;
}

}  // namespace qbond
