#include "qbond/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "qbond/analysis.hpp"
#include "energy_restore.hpp"
#include "parallel.hpp"

namespace qbond {

Simulation::Simulation(World world, const IntegratorConfig& config, double h)
    : world_(std::move(world)), integrator_(make_integrator(config)), h_(h) {
  const std::size_t n = world_.num_quanta();
  f_ext_.assign(n, Vec3::Zero());
  f_user_.assign(n, Vec3::Zero());
  EnergyLedger& l = world_.state.energy;
  if (!l.initialised) {
    const Energies e = energies(world_.model, world_.state);
    l.initial_total = e.total();
    l.initial_gravity = e.gravity;
    l.initial_time = world_.state.time;
    l.initialised = true;
  }
}

void Simulation::set_integrator(const IntegratorConfig& config) { integrator_ = make_integrator(config); }

const Adjacency& Simulation::adjacency() {
  if (adj_.version != world_.state.topology_version) build_adjacency(world_.model, world_.state, adj_);
  return adj_;
}

void Simulation::add_force(Index i, const Vec3& f) { f_user_.at(i) += f; }

void Simulation::clear_forces() { std::fill(f_user_.begin(), f_user_.end(), Vec3::Zero()); }

void Simulation::gather_external_forces() {
  const Model& m = world_.model;
  const std::size_t n = m.num_quanta();
  f_ext_.resize(n);
  for (std::size_t i = 0; i < n; ++i) f_ext_[i] = m.mass[i] * m.gravity + f_user_[i];
  for (const Load& load : m.loads) {
    if (load.quanta.empty()) continue;
    const Vec3 share = load.force / static_cast<double>(load.quanta.size());
    for (Index i : load.quanta) f_ext_[i] += share;
  }
}

void Simulation::begin_step() {
  const Adjacency& adj = adjacency();
  gather_external_forces();
  ctx_ = {h_, world_.state.time, world_.state.step};
  integrator_->project(world_.model, world_.state, adj, f_ext_, ctx_, projection_);
}

StepReport Simulation::step() {
  begin_step();
  return end_step();
}

StepReport Simulation::check_projection() const {
  const Model& m = world_.model;
  const State& s = world_.state;
  double worst = -1;
  Index who = 0;
  bool finite = true;
  for (std::size_t i = 0; i < m.num_quanta(); ++i) {
    const Vec3 v1 = s.v[i] + projection_.dv[i];
    const Vec3 x1 = s.x[i] + projection_.dx[i];
    if (!v1.allFinite() || !x1.allFinite()) {
      finite = false;
      who = static_cast<Index>(i);
      break;
    }
    const double speed = v1.norm();
    if (!m.is_kinematic(static_cast<Index>(i)) && speed > worst) {
      worst = speed;
      who = static_cast<Index>(i);
    }
  }
  StepReport r;
  if (finite && worst <= limits_.max_speed) return r;
  std::ostringstream msg;
  msg.precision(6);
  msg << "blow-up at step " << ctx_.step << " (t = " << ctx_.t << " s): ";
  if (!finite)
    msg << "quanta " << who << " would get a non-finite position or velocity";
  else
    msg << "quanta " << who << " would reach speed " << worst << " m/s (limit " << limits_.max_speed
        << " m/s)";
  msg << "; the world keeps the state before this step";
  r.status = StepReport::Status::blowup;
  r.message = msg.str();
  r.worst = who;
  return r;
}

StepReport Simulation::check_energy() const {
  StepReport r;
  if (!track_energy_) return r;
  const Model& m = world_.model;
  const State& s = world_.state;
  const EnergyLedger& l = s.energy;
  const int threads = integrator_->config().threads;
  const Energies e = energies(m, s, threads);
  // External forces can also give energy before they have done measurable work (a step from
  // rest changes velocity before position): allow the kinetic energy their impulse over the
  // elapsed time would give each free quanta, Σ |f_ext t|² / (2 m).
  const double t = s.time - l.initial_time;
  const double impulse = deterministic_sum(m.num_quanta(), threads, [&](std::size_t i) {
    return 0.5 * m.inv_mass[i] * (t * f_ext_[i]).squaredNorm();
  });
  const double available = (l.initial_total - l.initial_gravity) + std::abs(e.gravity - l.initial_gravity) +
                           std::abs(l.work_loads) + std::abs(l.work_anchors) + impulse;
  const double held = e.kinetic + e.bonds;
  if (held <= limits_.energy_growth * available + limits_.energy_floor) return r;
  const auto [speed, who] = max_speed(m, s);
  std::ostringstream msg;
  msg.precision(6);
  msg << "blow-up at step " << s.step << " (t = " << s.time << " s): energy runaway, kinetic + bond energy "
      << held << " J exceeds " << limits_.energy_growth << " x the " << available
      << " J the system could have gained; fastest quanta " << who << " at " << speed << " m/s";
  r.status = StepReport::Status::blowup;
  r.message = msg.str();
  r.worst = who;
  return r;
}

void Simulation::update_ledger() {
  // Charges this step's work and damping losses before the projection is applied. Loads are
  // constant over the step (their work is exact); anchors' bond forces use the trapezoid rule;
  // dampers are charged at the velocity v + θ Δv at which the integrator evaluated them.
  const Model& m = world_.model;
  const State& s = world_.state;
  const Projection& p = projection_;
  EnergyLedger& l = world_.state.energy;
  const double h = ctx_.h, theta = integrator_->damping_theta(), phi = integrator_->damping_direction_theta();
  const bool discrete_gradient = integrator_->discrete_gradient();
  const int threads = integrator_->config().threads;
  const double loads = deterministic_sum(m.num_quanta(), threads, [&](std::size_t i) {
    return m.is_kinematic(static_cast<Index>(i)) ? 0.0 : (f_ext_[i] - m.mass[i] * m.gravity).dot(p.dx[i]);
  });
  auto relative_velocity = [&](Index i, Index j) -> Vec3 {
    return (s.v[j] + theta * p.dv[j]) - (s.v[i] + theta * p.dv[i]);
  };
  // The bond at the fraction φ of the step where the integrator took the axial damper's direction.
  auto damper_bond = [&](Index i, Index j) -> Vec3 { return s.x[j] - s.x[i] + phi * (p.dx[j] - p.dx[i]); };
  const double damping = deterministic_sum(m.num_bonds(), threads, [&](std::size_t b) {
    if (!s.alive[b]) return 0.0;
    const Index i = m.bond_i[b], j = m.bond_j[b];
    const Vec3 dp = damper_bond(i, j);
    const double rp = dp.norm();
    if (!(rp > 0)) return 0.0;
    const Vec3 w = relative_velocity(i, j);
    const double wu = w.dot(dp / rp);
    return h * m.damping[b] * (m.damping_model[b] == DampingModel::axial ? wu * wu : w.squaredNorm());
  });
  const double anchors = deterministic_sum(m.num_bonds(), threads, [&](std::size_t b) {
    const Index i = m.bond_i[b], j = m.bond_j[b];
    const bool ki = m.is_kinematic(i), kj = m.is_kinematic(j);
    if (!s.alive[b] || (!ki && !kj)) return 0.0;
    const Vec3 d0 = s.x[j] - s.x[i];
    const double r0 = d0.norm();
    if (!(r0 > 0)) return 0.0;
    const Vec3 w = relative_velocity(i, j);
    const double D = m.damping[b];
    // Force of the bond on i, averaged over the step; the bond pushes j with the opposite force:
    // the trapezoid rule, or the discrete gradient T̄ d_mid / r̄ the integrator itself applied.
    const Vec3 d1 = d0 + p.dx[j] - p.dx[i];
    const double r1 = d1.norm();
    Vec3 fi;
    if (discrete_gradient) {
      const MeanTension mt = mean_tension(m.law[b], r0, r1, s.rest[b], m.stiffness[b], m.eps[b]);
      fi = (mt.T / (0.5 * (r0 + r1))) * (0.5 * (d0 + d1));
    } else {
      const double T0 = m.law_at(b, r0, s.rest[b]).T;
      const double T1 = m.law_at(b, r1, s.rest[b]).T;
      const Vec3 u0 = d0 / r0;
      fi = 0.5 * (T0 * u0 + (r1 > 0 ? Vec3(T1 * d1 / r1) : Vec3::Zero()));
    }
    const Vec3 dp = damper_bond(i, j);
    const double rp = dp.norm();
    const Vec3 up = rp > 0 ? Vec3(dp / rp) : Vec3::Zero();
    fi += m.damping_model[b] == DampingModel::axial ? Vec3(D * w.dot(up) * up) : Vec3(D * w);
    // A prescribed quanta does on the structure the work the bond's force on it resists.
    double work = 0;
    if (ki) work -= fi.dot(p.dx[i]);
    if (kj) work += fi.dot(p.dx[j]);
    return work;
  });
  l.work_loads += loads;
  l.work_anchors += anchors;
  l.dissipated_damping += damping;
}

StepReport Simulation::end_step() {
  State& s = world_.state;
  if (keep_last_good_) last_good_ = s;  // before heuristics and ledger: a rollback undoes both
  const bool restore = integrator_->config().restore_energy;
  const EnergyLedger books = s.energy;  // the step's work and dissipation are what the ledger adds
  const double e_start = restore ? energies(world_.model, s, integrator_->config().threads).total() : 0.0;
  events_.clear();
  if (!heuristics_.empty()) {
    dv_forces_ = projection_.dv;
    const HeuristicContext hc{ctx_, adjacency(), integrator_->config().threads, events_, dv_forces_};
    for (auto& h : heuristics_) h->apply(world_, projection_, hc);
  }
  if (StepReport r = check_projection(); r.status != StepReport::Status::ok) {
    if (keep_last_good_) {
      s = last_good_;  // heuristics may have edited bonds already
      world_.sync_formed_bonds();
      events_.clear();
    }
    return r;
  }
  if (track_energy_ || restore) update_ledger();

  const Model& m = world_.model;
  parallel_for(m.num_quanta(), integrator_->config().threads, [&](std::size_t i) {
    s.x[i] += projection_.dx[i];
    s.v[i] += projection_.dv[i];
  });
  const double t1 = ctx_.t + ctx_.h;
  // Kinematic quanta land exactly on their prescribed path (no round-off drift).
  for (const Motion& motion : m.motions)
    for (std::size_t k = 0; k < motion.quanta.size(); ++k)
      motion.at(k, t1, s.x[motion.quanta[k]], s.v[motion.quanta[k]]);
  s.time = t1;
  s.step = ctx_.step + 1;
  s.warm.swap(projection_.warm);
  clear_forces();
  if (restore) {
    // E(end) should be E(start) + work − dissipation; what is missing the integrator removed.
    const EnergyLedger& l = s.energy;
    const double target = e_start + (l.work_loads - books.work_loads) + (l.work_anchors - books.work_anchors) -
                          (l.dissipated_damping - books.dissipated_damping) -
                          (l.dissipated_heuristics - books.dissipated_heuristics);
    const double e_end = energies(m, s, integrator_->config().threads).total();
    scale_internal_velocities(m, adjacency(), s, target - e_end);
  }

  StepReport r = check_energy();
  if (r.status != StepReport::Status::ok && keep_last_good_) {
    s = last_good_;
    world_.sync_formed_bonds();
    events_.clear();
    r.message += "; the world keeps the state before this step";
  }
  if (r.status == StepReport::Status::ok)
    for (Observer* o : observers_) o->observe(m, s, ctx_);
  return r;
}

}  // namespace qbond
