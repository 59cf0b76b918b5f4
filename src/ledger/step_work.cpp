#include "ledger/step_work.hpp"

#include <cmath>

#include "core/parallel.hpp"

namespace qbond {

StepWork step_work(const Model& m, const State& s, const Adjacency& adj, const Projection& p,
                   const AppliedState& a, const std::vector<Vec3>& f_ext, double h, const LedgerHints& hints,
                   int threads) {
  const double theta = hints.damping_theta, phi = hints.damping_direction_theta;
  const double loads = deterministic_sum(m.num_quanta(), threads, [&](std::size_t i) {
    return m.is_kinematic(static_cast<Index>(i)) ? 0.0 : (f_ext[i] - m.mass[i] * m.gravity).dot(p.dx[i]);
  });
  auto relative_velocity = [&](Index i, Index j) -> Vec3 {
    return (s.v[j] + theta * p.dv[j]) - (s.v[i] + theta * p.dv[i]);
  };
  // The bond at the fraction φ of the step where the integrator took the axial damper's direction.
  auto damper_bond = [&](Index i, Index j) -> Vec3 { return s.x[j] - s.x[i] + phi * (p.dx[j] - p.dx[i]); };
  const BondStepSums bonds = bond_step_sums(m, s, a, h, theta, phi, hints.backward_euler, threads);
  // Only bonds with a moving prescribed end do work on the anchors: found through those quanta's
  // adjacency, each bond once (from its first such end), summed in quanta order. A prescribed
  // quanta that stays put this step (an anchor) does none.
  auto anchor_work = [&](std::size_t b) {
    const Index i = s.bonds.i[b], j = s.bonds.j[b];
    const bool ki = m.is_kinematic(i), kj = m.is_kinematic(j);
    const Vec3 d0 = s.x[j] - s.x[i];
    const double r0 = d0.norm();
    if (!(r0 > 0)) return 0.0;
    const Vec3 w = relative_velocity(i, j);
    const double D = s.bonds.damping[b];
    // Force of the bond on i, averaged over the step; the bond pushes j with the opposite force:
    // the trapezoid rule, or the discrete gradient T̄ d_mid / r̄ the integrator itself applied.
    const Vec3 d1 = d0 + p.dx[j] - p.dx[i];
    const double r1 = d1.norm();
    Vec3 fi;
    if (hints.discrete_gradient) {
      const MeanTension mt = s.bonds.mean_tension_at(m.shapes, b, r0, r1, s.bonds.rest[b]);
      fi = (mt.T / (0.5 * (r0 + r1))) * (0.5 * (d0 + d1));
    } else {
      const double T0 = s.bonds.law_at(m.shapes, b, r0, s.bonds.rest[b]).T;
      const double T1 = s.bonds.law_at(m.shapes, b, r1, s.bonds.rest[b]).T;
      const Vec3 u0 = d0 / r0;
      fi = 0.5 * (T0 * u0 + (r1 > 0 ? Vec3(T1 * d1 / r1) : Vec3::Zero()));
    }
    const Vec3 dp = damper_bond(i, j);
    const double rp = dp.norm();
    const Vec3 up = rp > 0 ? Vec3(dp / rp) : Vec3::Zero();
    fi += s.bonds.damping_model[b] == DampingModel::axial ? Vec3(D * w.dot(up) * up) : Vec3(D * w);
    // A prescribed quanta does on the structure the work the bond's force on it resists.
    double work = 0;
    if (ki) work -= fi.dot(p.dx[i]);
    if (kj) work += fi.dot(p.dx[j]);
    return work;
  };
  auto moving = [&](std::size_t q) { return m.is_kinematic(static_cast<Index>(q)) && p.dx[q] != Vec3::Zero(); };
  const double anchors = deterministic_sum(m.num_quanta(), threads, [&](std::size_t q) {
    if (!moving(q)) return 0.0;
    double work = 0;
    for (Index e = adj.offset[q]; e < adj.offset[q + 1]; ++e) {
      const Index b = adj.bond[e];
      if (s.bonds.i[b] == q || !moving(s.bonds.i[b])) work += anchor_work(b);
    }
    return work;
  });
  return {loads, anchors, bonds.damping, bonds.energy_after, bonds.step_loss};
}

}  // namespace qbond
