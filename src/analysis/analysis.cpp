#include "qbond/analysis/analysis.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "ledger/energy_sums.hpp"
#include "core/parallel.hpp"

namespace qbond {

Energies quanta_energies(const Model& model, const State& state, int threads) {
  // Both sums folded as deterministic_sum folds each: the same chunks, in the same order.
  struct Pair {
    double kinetic = 0, potential = 0;
  };
  auto fold = [&](Pair p, std::size_t i) {
    const bool free = !model.is_kinematic(static_cast<Index>(i));
    p.kinetic += free ? 0.5 * model.mass[i] * state.v[i].squaredNorm() : 0.0;
    p.potential += free ? model.mass[i] * model.gravity.dot(state.x[i]) : 0.0;
    return p;
  };
  auto combine = [](Pair a, Pair b) { return Pair{a.kinetic + b.kinetic, a.potential + b.potential}; };
  const Pair p = deterministic_reduce(model.num_quanta(), threads, Pair{}, fold, combine);
  Energies e;
  e.kinetic = p.kinetic;
  e.gravity = -p.potential;
  return e;
}

void open_ledger(const Model& model, const State& state, EnergyLedger& ledger) {
  if (ledger.initialised) return;
  const Energies e = energies(model, state);
  ledger.initial_total = e.total();
  ledger.initial_gravity = e.gravity;
  ledger.initial_time = state.time;
  ledger.initialised = true;
}

Energies energies(const Model& model, const State& state, int threads) {
  Energies e = quanta_energies(model, state, threads);
  e.bonds = bond_energy_sum(model, state, threads);
  return e;
}

Vec3 linear_momentum(const Model& model, const State& state) {
  Vec3 p = Vec3::Zero();
  for (std::size_t i = 0; i < model.num_quanta(); ++i)
    if (!model.is_kinematic(static_cast<Index>(i))) p += model.mass[i] * state.v[i];
  return p;
}

Vec3 angular_momentum(const Model& model, const State& state) {
  Vec3 l = Vec3::Zero();
  for (std::size_t i = 0; i < model.num_quanta(); ++i)
    if (!model.is_kinematic(static_cast<Index>(i))) l += model.mass[i] * state.x[i].cross(state.v[i]);
  return l;
}

std::pair<double, Index> max_speed(const Model& model, const State& state) {
  double best = 0;
  Index who = static_cast<Index>(model.num_quanta());
  for (std::size_t i = 0; i < model.num_quanta(); ++i) {
    if (model.is_kinematic(static_cast<Index>(i))) continue;
    const double s = state.v[i].norm();
    if (!(s <= best)) {  // also catches NaN, which then names the quanta
      best = s;
      who = static_cast<Index>(i);
      if (std::isnan(s)) break;
    }
  }
  return {best, who};
}

void bond_tension_strain(const Model& model, const State& state, std::vector<double>& tension,
                         std::vector<double>& strain) {
  const std::size_t nb = state.bonds.size();
  tension.assign(nb, 0.0);
  strain.assign(nb, 0.0);
  for (std::size_t b = 0; b < nb; ++b) {
    if (!state.bonds.alive[b]) continue;
    const double r = (state.x[state.bonds.j[b]] - state.x[state.bonds.i[b]]).norm();
    const double L = state.bonds.rest[b];
    tension[b] = state.bonds.law_at(model.shapes, b, r, L).T;
    strain[b] = L > 0 ? (r - L) / L : 0.0;
  }
}

EnergyBudget energy_budget(const Model& model, const State& state) {
  EnergyBudget b;
  const EnergyLedger& l = state.energy;
  b.now = energies(model, state);
  b.initial_total = l.initial_total;
  b.work_loads = l.work_loads;
  b.work_anchors = l.work_anchors;
  b.dissipated_damping = l.dissipated_damping;
  b.dissipated_heuristics = l.dissipated_heuristics;
  b.dissipated_contact = l.dissipated_contact;
  b.contact_stored = l.contact_stored;
  b.numerical_damping = l.numerical_damping;
  b.dissipated_numerical = l.work_loads + l.work_anchors - l.dissipated_damping - l.dissipated_heuristics -
                           l.dissipated_contact - l.numerical_damping -
                           (b.now.total() + l.contact_stored - l.initial_total);
  return b;
}

double max_angular_frequency(const Model& m, const State& state) {
  const auto n = static_cast<Eigen::Index>(m.num_quanta());
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (std::size_t b = 0; b < state.bonds.size(); ++b) {
    if (!state.bonds.alive[b]) continue;
    const Index i = state.bonds.i[b], j = state.bonds.j[b];
    const Vec3 d = state.x[j] - state.x[i];
    const double r = d.norm();
    const LawValue lv = state.bonds.law_at(m.shapes, b, r, state.bonds.rest[b]);
    const Mat3 Kb = stiffness_block(lv.T, lv.dT, r, d / r, false);
    K.block<3, 3>(3 * i, 3 * i) += Kb;
    K.block<3, 3>(3 * j, 3 * j) += Kb;
    K.block<3, 3>(3 * i, 3 * j) -= Kb;
    K.block<3, 3>(3 * j, 3 * i) -= Kb;
  }
  Eigen::VectorXd s(3 * n);
  for (Eigen::Index i = 0; i < n; ++i) s.segment<3>(3 * i).setConstant(std::sqrt(m.inv_mass[i]));  // kinematic: 0
  const Eigen::MatrixXd A = s.asDiagonal() * K * s.asDiagonal();
  return std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(A).eigenvalues().maxCoeff()));
}

}  // namespace qbond
