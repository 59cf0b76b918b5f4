#include "qbond/simulation/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <sstream>

#include "qbond/analysis/analysis.hpp"
#include "integrators/energy_restore.hpp"
#include "core/parallel.hpp"
#include "core/simd.hpp"
#include "ledger/step_work.hpp"

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

void Simulation::set_integrator(const IntegratorConfig& config) {
  integrator_ = make_integrator(config);
  world_.state.carry = std::monostate{};  // the carry-over was the old integrator's
}

const Adjacency& Simulation::adjacency() {
  if (adj_.version != world_.state.topology_version) build_adjacency(world_.model, world_.state, adj_);
  return adj_;
}

void Simulation::add_force(Index i, const Vec3& f) {
  f_user_.at(i) += f;
  forces_queued_ = true;
}

void Simulation::clear_forces() {
  if (!forces_queued_) return;  // most steps: nothing to clear, no pass over the quanta
  std::fill(f_user_.begin(), f_user_.end(), Vec3::Zero());
  forces_queued_ = false;
}

void Simulation::gather_external_forces() {
  const Model& m = world_.model;
  const std::size_t n = m.num_quanta();
  f_ext_.resize(n);
  const bool user = forces_queued_;  // else f_user_ is all zero and not read
  parallel_for(n, integrator_->config().threads, [&](std::size_t i) {
    f_ext_[i] = m.mass[i] * m.gravity;
    if (user) f_ext_[i] += f_user_[i];
  });
  for (const Load& load : m.loads) {
    if (load.quanta.empty()) continue;
    const Vec3 share = load.force / static_cast<double>(load.quanta.size());
    for (Index i : load.quanta) f_ext_[i] += share;
  }
}

void Simulation::begin_step() { project(false); }

void Simulation::project(bool direct) {
  const Adjacency& adj = adjacency();
  // Gravity alone, in a direct step, is formed by an integrator that can in its own passes: no
  // pass over the quanta to fill f_ext, and none of its reads.
  static const std::vector<Vec3> kGravityAlone;
  const bool gravity_alone =
      direct && !forces_queued_ && world_.model.loads.empty() && integrator_->forms_gravity();
  if (!gravity_alone) gather_external_forces();
  ctx_ = {.h = h_,
          .t = world_.state.time,
          .step = world_.state.step,
          .direct = direct,
          .max_speed = limits_.max_speed};
  integrator_->project(world_.model, world_.state, adj, gravity_alone ? kGravityAlone : f_ext_, ctx_,
                       projection_);
}

StepReport Simulation::step() {
  // Nothing between the projection and its application reads dx and dv without heuristics and the
  // ledger: the integrator may then hand over the state to apply (StepContext::direct).
  project(heuristics_.empty() && !track_energy_ && !integrator_->config().restore_energy);
  return end_step();
}

namespace {

// xn = x + dx and vn = v + dv for quanta [lo, hi); whether all are finite (x − x is 0 for every
// finite x, NaN otherwise) and no free quanta is faster than sqrt(limit2). Branch-free, so the
// loop vectorises.
QBOND_VECTOR_CLONES bool advance_checked(const double* x, const double* v, const double* dx, const double* dv,
                                         const double* inv_mass, double limit2, double* xn, double* vn,
                                         std::size_t lo, std::size_t hi) {
  std::uint64_t bad = 0;
  QBOND_SIMD_OR(bad) for (std::size_t q = lo; q < hi; ++q) {
    double speed2 = 0, nan_if_bad = 0;
    QBOND_UNROLL(3) for (std::size_t c = 0; c < 3; ++c) {
      const std::size_t e = 3 * q + c;
      const double x1 = x[e] + dx[e], v1 = v[e] + dv[e];
      xn[e] = x1;
      vn[e] = v1;
      nan_if_bad += (x1 - x1) + (v1 - v1);
      speed2 += v1 * v1;
    }
    bad |= static_cast<std::uint64_t>((nan_if_bad != 0) | ((speed2 > limit2) & (inv_mass[q] != 0)));
  }
  return bad == 0;
}

}  // namespace

bool Simulation::advance(double limit2) {
  const Model& m = world_.model;
  const State& s = world_.state;
  const std::size_t n = m.num_quanta();
  next_x_.resize(n);
  next_v_.resize(n);
  const double* x = s.x.data()->data();
  const double* v = s.v.data()->data();
  const double* dx = projection_.dx.data()->data();
  const double* dv = projection_.dv.data()->data();
  double* xn = next_x_.data()->data();
  double* vn = next_v_.data()->data();
  // The prescribed quanta exactly on their path (place_kinematic), so that they do not drift by
  // round-off, placed with their range (PrescribedAt says why).
  prescribed_.update(m, ctx_.t + ctx_.h);
  auto fast = [&](std::size_t lo, std::size_t hi) {
    const bool ok = advance_checked(x, v, dx, dv, m.inv_mass.data(), limit2, xn, vn, lo, hi);
    prescribed_.place(lo, hi, next_x_.data(), next_v_.data());
    return ok;
  };
  return reduce_chunks(n, integrator_->config().threads, true, fast, std::logical_and<>{});
}

StepReport Simulation::check_projection() {
  const Model& m = world_.model;
  const double limit2 = limits_.max_speed * limits_.max_speed;
  // First the plain test every step passes, no free quanta too fast and nothing non-finite, with
  // the state the step will apply formed into next_x_, next_v_: by the integrator (StepContext::
  // direct), else by advance.
  Projection::Applied& applied = projection_.applied;
  if (applied.written) {
    next_x_.swap(applied.x);
    next_v_.swap(applied.v);
  }
  if (applied.written ? applied.ok : advance(limit2)) return {};
  // A step to stop: the first quanta (by index) with a non-finite result, else the fastest free
  // one (the first of equals), for the message: a reduction over fixed chunks, the same on any
  // thread count.
  struct Worst {
    double speed2 = -1;  // squared: a square root only for the message
    Index who = 0;
    bool finite = true;
  };
  auto fold = [&](Worst w, std::size_t i) {
    if (!w.finite) return w;
    const Vec3& v1 = next_v_[i];
    const Vec3& x1 = next_x_[i];
    if (!v1.allFinite() || !x1.allFinite()) return Worst{w.speed2, static_cast<Index>(i), false};
    const double speed2 = v1.squaredNorm();
    if (!m.is_kinematic(static_cast<Index>(i)) && speed2 > w.speed2)
      return Worst{speed2, static_cast<Index>(i), true};
    return w;
  };
  auto combine = [](const Worst& a, const Worst& b) {
    return !a.finite || (b.finite && b.speed2 <= a.speed2) ? a : b;
  };
  const auto [worst2, who, finite] =
      deterministic_reduce(m.num_quanta(), integrator_->config().threads, Worst{}, fold, combine);
  StepReport r;
  if (finite && worst2 <= limit2) return r;
  std::ostringstream msg;
  msg.precision(6);
  msg << "blow-up at step " << ctx_.step << " (t = " << ctx_.t << " s): ";
  if (!finite)
    msg << "quanta " << m.quanta_id[who] << " would get a non-finite position or velocity";
  else
    msg << "quanta " << m.quanta_id[who] << " would reach speed " << std::sqrt(worst2) << " m/s (limit "
        << limits_.max_speed << " m/s)";
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
  // The bonds' energy update_ledger summed at the positions this step applied (the same pass as
  // the dampers' work), but for round-off where a prescribed quanta landed on its path instead.
  Energies e = quanta_energies(m, s, threads);
  e.bonds = bonds_after_;
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
      << " J the system could have gained; fastest quanta " << m.quanta_id[who] << " at " << speed << " m/s";
  r.status = StepReport::Status::blowup;
  r.message = msg.str();
  r.worst = who;
  return r;
}

void Simulation::update_ledger() {
  // Charges this step's work and damping losses before the projection is applied (step_work.hpp).
  // A Newton integrator that split the step into substeps reports the anchors' and dampers' work
  // summed over them (Projection::has_work): the whole-step estimate would not be what it applied.
  const Projection& p = projection_;
  EnergyLedger& l = world_.state.energy;
  const StepWork w = step_work(world_.model, world_.state, adjacency(), p, {next_x_, next_v_}, f_ext_, ctx_.h,
                               integrator_->damping_theta(), integrator_->damping_direction_theta(),
                               integrator_->discrete_gradient(), integrator_->config().threads);
  l.work_loads += w.loads;
  l.work_anchors += p.has_work ? p.work_anchors : w.anchors;
  l.dissipated_damping += p.has_work ? p.dissipated_damping : w.damping;
  bonds_after_ = w.bonds_after;
}

namespace {

// Arrays moved out of a state and back, so that a copy of the state leaves them out: positions,
// velocities and the integrator's carry-over (always: see copy_last_good) and, with `bonds`, the
// per-bond arrays.
struct KeptArrays {
  std::vector<Vec3> x, v;
  Carry carry;
  std::vector<double> rest;
  std::vector<std::uint8_t> alive;
  std::vector<double> bond_time;
  std::vector<FormedBond> formed;
  KeptArrays(State& s, bool bonds) : x(std::move(s.x)), v(std::move(s.v)) {
    carry.swap(s.carry);
    if (!bonds) return;
    rest = std::move(s.rest);
    alive = std::move(s.alive);
    bond_time = std::move(s.bond_time);
    formed = std::move(s.formed);
  }
  void put_back(State& s, bool bonds) {
    s.x = std::move(x);
    s.v = std::move(v);
    s.carry.swap(carry);
    if (!bonds) return;
    s.rest = std::move(rest);
    s.alive = std::move(alive);
    s.bond_time = std::move(bond_time);
    s.formed = std::move(formed);
  }
};

}  // namespace

void Simulation::copy_last_good(bool save, bool applied) {
  State& s = world_.state;
  if (save) last_good_has_bonds_ = !heuristics_.empty();
  // Only heuristics edit bonds during a step: without them the copy leaves out the bond arrays,
  // most of a lattice's state, and the world's state keeps its own. Positions, velocities and the
  // carry-over are never copied: until end_step swaps in the step's own they are the ones before
  // the step, and after the swap next_x_, next_v_ and the projection hold those.
  const bool bonds = !last_good_has_bonds_;
  KeptArrays kept(s, bonds);
  if (save)
    last_good_ = s;
  else
    s = last_good_;
  kept.put_back(s, bonds);
  if (applied) {
    s.x.swap(next_x_);
    s.v.swap(next_v_);
    s.carry.swap(projection_.carry);
  }
}

StepReport Simulation::end_step() {
  State& s = world_.state;
  if (keep_last_good_) copy_last_good(true);  // before heuristics and ledger: a rollback undoes both
  const bool restore = integrator_->config().restore_energy;
  const EnergyLedger books = s.energy;  // the step's work and dissipation are what the ledger adds
  const double e_start = restore ? energies(world_.model, s, integrator_->config().threads).total() : 0.0;
  events_.clear();
  if (!heuristics_.empty()) {
    dv_forces_ = projection_.dv;
    const HeuristicContext hc{ctx_, adjacency(), integrator_->config().threads, events_, dv_forces_};
    for (auto& h : heuristics_) h->apply(world_, projection_, hc);
    if (projection_.bonds_edited) drop_after_bond_edit(projection_.carry);
  }
  if (StepReport r = check_projection(); r.status != StepReport::Status::ok) {
    if (keep_last_good_) {
      copy_last_good(false);  // heuristics may have edited bonds already
      world_.sync_formed_bonds();
      events_.clear();
    }
    return r;
  }
  if (track_energy_ || restore) update_ledger();

  const Model& m = world_.model;
  s.x.swap(next_x_);  // x + Δx and v + Δv (the prescribed quanta placed), formed by check_projection
  s.v.swap(next_v_);
  s.time = ctx_.t + ctx_.h;
  s.step = ctx_.step + 1;
  s.carry.swap(projection_.carry);
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
    copy_last_good(false, true);
    world_.sync_formed_bonds();
    events_.clear();
    r.message += "; the world keeps the state before this step";
  }
  if (r.status == StepReport::Status::ok)
    for (Observer* o : observers_) o->observe(m, s, ctx_);
  return r;
}

}  // namespace qbond
