#include "qbond/simulation/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <stdexcept>

#include "qbond/analysis/analysis.hpp"
#include "integrators/advance.hpp"
#include "integrators/energy_restore.hpp"
#include "core/parallel.hpp"
#include "ledger/ledger_stage.hpp"

namespace qbond {

// What the stages hand each other besides the projection, and their buffers.
struct Simulation::Scratch {
  bool gravity_alone = false;  // f_ext_ not gathered: the integrator forms gravity (gather_forces)
  bool in_place = false;       // the integrate stage advanced the step in place: `next` is written
  Advanced next;               // the state the step applies, x + dx and v + dv, and its check
  PrescribedAt prescribed;     // where the check stage places the prescribed quanta
  LedgerStage ledger;          // with the substeps of a step taken in substeps
  double bonds_after = 0;      // the bonds' energy after the step, from the ledger [J]
  EnergyLedger books;          // the ledger before the step (energy restoration)
  double e_start = 0;          // E before the step (energy restoration) [J]
};

namespace {
// Every integrator comes from make_step_integrator: its private paths (advance.hpp).
StepIntegrator& stepper(const std::unique_ptr<Integrator>& integrator) {
  return static_cast<StepIntegrator&>(*integrator);
}
}  // namespace

// ---- The step -----------------------------------------------------------------------------------

StepReport Simulation::step() {
  // Nothing after the integrator reads dx and dv without heuristics and the ledger: it may then
  // advance the state in place, in its own passes.
  const bool in_place = heuristics_.empty() && !ledger_on();
  gather_forces(in_place);
  integrate(in_place);
  return end_step();
}

void Simulation::begin_step() {
  gather_forces(false);
  integrate(false);
}

StepReport Simulation::end_step() {
  if (keep_last_good_) copy_last_good(true);  // before heuristics and ledger: a rollback undoes both
  open_books();
  run_heuristics();
  if (StepReport r = check(); r.status != StepReport::Status::ok) return roll_back(std::move(r), false);
  if (ledger_on()) charge_ledger();
  apply();
  restore_energy();
  if (StepReport r = check_energy(); r.status != StepReport::Status::ok) return roll_back(std::move(r), true);
  observe();
  return {};
}

// ---- The stages ---------------------------------------------------------------------------------

void Simulation::gather_forces(bool in_place) {
  const Model& m = world_.model;
  // Gravity alone, in a step advanced in place, is formed by an integrator that can in its own
  // passes: no pass over the quanta to fill f_ext, and none of its reads.
  scratch_->gravity_alone = in_place && !forces_queued_ && m.loads.empty() && stepper(integrator_).forms_gravity();
  if (scratch_->gravity_alone) return;
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

void Simulation::integrate(bool in_place) {
  Scratch& k = *scratch_;
  StepIntegrator& integrator = stepper(integrator_);
  const Adjacency& adj = adjacency();
  static const std::vector<Vec3> kGravityAlone;  // StepIntegrator::forms_gravity
  const std::vector<Vec3>& f_ext = k.gravity_alone ? kGravityAlone : f_ext_;
  ctx_ = {.h = h_, .t = world_.state.time, .step = world_.state.step};
  k.ledger.begin(integrator.ledger_hints(), integrator.config().threads);
  integrator.set_substep_ledger(ledger_on() ? &k.ledger : nullptr);
  k.in_place = in_place;
  if (!in_place) return integrator.project(world_.model, world_.state, adj, f_ext, ctx_, projection_);
  k.next.max_speed = limits_.max_speed;
  integrator.advance(world_.model, world_.state, adj, f_ext, ctx_, projection_, k.next);
}

void Simulation::open_books() {
  if (!integrator_->config().restore_energy) return;
  scratch_->books = world_.state.energy;  // the step's work and dissipation are what the ledger adds
  scratch_->e_start = energies(world_.model, world_.state, integrator_->config().threads).total();
}

void Simulation::run_heuristics() {
  events_.clear();
  if (heuristics_.empty()) return;
  dv_forces_ = projection_.dv;
  const HeuristicContext hc{ctx_, adjacency(), integrator_->config().threads, events_, dv_forces_};
  for (auto& h : heuristics_) h->apply(world_.model, world_.state, projection_, hc);
  if (projection_.bonds_edited) drop_after_bond_edit(projection_.carry);
}

StepReport Simulation::check() {
  // The plain test every step passes, no free quanta too fast and nothing non-finite, with the
  // state the step will apply formed: by the integrator when it advanced in place, else here.
  Scratch& k = *scratch_;
  const int threads = integrator_->config().threads;
  if (!k.in_place) {
    k.next.max_speed = limits_.max_speed;
    apply_checked(world_.model, world_.state, projection_, ctx_.t + ctx_.h, threads, k.prescribed, k.next);
  }
  if (k.next.ok) return {};
  const Blowup b = find_blowup(world_.model, k.next.x, k.next.v, limits_.max_speed, ctx_, threads);
  if (!b.found) return {};
  StepReport r;
  r.status = StepReport::Status::blowup;
  r.message = b.message + "; the world keeps the state before this step";
  r.worst = b.who;
  return r;
}

void Simulation::charge_ledger() {
  // Before the state moves: the ledger reads the state before the step and the one it applies.
  Scratch& k = *scratch_;
  k.bonds_after = k.ledger.charge_step(world_.model, world_.state, adjacency(), projection_, {k.next.x, k.next.v},
                                       f_ext_, ctx_.h);
}

void Simulation::apply() {
  State& s = world_.state;
  s.x.swap(scratch_->next.x);  // x + Δx and v + Δv (the prescribed quanta placed), from check
  s.v.swap(scratch_->next.v);
  s.time = ctx_.t + ctx_.h;
  s.step = ctx_.step + 1;
  s.carry.swap(projection_.carry);
  clear_forces();
}

void Simulation::restore_energy() {
  if (!integrator_->config().restore_energy) return;
  // E(end) should be E(start) + work − dissipation; what is missing the integrator removed.
  const Model& m = world_.model;
  State& s = world_.state;
  const EnergyLedger& l = s.energy;
  const EnergyLedger& books = scratch_->books;
  const double target = scratch_->e_start + (l.work_loads - books.work_loads) +
                        (l.work_anchors - books.work_anchors) -
                        (l.dissipated_damping - books.dissipated_damping) -
                        (l.dissipated_heuristics - books.dissipated_heuristics);
  const double e_end = energies(m, s, integrator_->config().threads).total();
  scale_internal_velocities(m, adjacency(), s, target - e_end);
}

StepReport Simulation::check_energy() const {
  StepReport r;
  if (!track_energy_) return r;
  const Model& m = world_.model;
  const State& s = world_.state;
  const EnergyLedger& l = s.energy;
  const int threads = integrator_->config().threads;
  // The bonds' energy the ledger summed at the positions this step applied (the same pass as
  // the dampers' work), but for round-off where a prescribed quanta landed on its path instead.
  Energies e = quanta_energies(m, s, threads);
  e.bonds = scratch_->bonds_after;
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

void Simulation::observe() {
  for (Observer* o : observers_) o->observe(world_.model, world_.state, ctx_);
}

StepReport Simulation::roll_back(StepReport r, bool applied) {
  if (!keep_last_good_) return r;
  copy_last_good(false, applied);  // heuristics may have edited bonds already
  events_.clear();
  if (applied) r.message += "; the world keeps the state before this step";
  return r;
}

// ---- Setup and state ----------------------------------------------------------------------------

Simulation::Simulation(World world, const IntegratorConfig& config, double h)
    : world_(std::move(world)), integrator_(make_step_integrator(config)), h_(h), scratch_(std::make_unique<Scratch>()) {
  checked_thread_count(config.threads);  // before any parallel region: OpenMP crashes on absurd counts
  if (!world_.model.obstacles.empty() && config.type != IntegratorType::coupled_implicit)
    throw std::invalid_argument("the model's obstacles are held inside the coupled_implicit step's solve, not by " +
                                std::string(to_string(config.type)) + " (make them projection rules)");
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

Simulation::Simulation(Simulation&&) noexcept = default;
Simulation& Simulation::operator=(Simulation&&) noexcept = default;
Simulation::~Simulation() = default;

void Simulation::set_integrator(const IntegratorConfig& config) {
  checked_thread_count(config.threads);
  integrator_ = make_step_integrator(config);
  world_.state.carry = std::monostate{};  // the carry-over was the old integrator's
}

const Adjacency& Simulation::adjacency() {
  if (adj_.version != world_.state.topology_version()) build_adjacency(world_.model, world_.state, adj_);
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

namespace {

// Arrays moved out of a state and back, so that a copy of the state leaves them out: positions,
// velocities and the integrator's carry-over (always: see copy_last_good) and, with `with_bonds`,
// the bonds.
struct KeptArrays {
  std::vector<Vec3> x, v;
  Carry carry;
  Bonds bonds;
  KeptArrays(State& s, bool with_bonds) : x(std::move(s.x)), v(std::move(s.v)) {
    carry.swap(s.carry);
    if (with_bonds) bonds = std::move(s.bonds);
  }
  void put_back(State& s, bool with_bonds) {
    s.x = std::move(x);
    s.v = std::move(v);
    s.carry.swap(carry);
    if (with_bonds) s.bonds = std::move(bonds);
  }
};

}  // namespace

void Simulation::copy_last_good(bool save, bool applied) {
  State& s = world_.state;
  if (save) last_good_has_bonds_ = !heuristics_.empty();
  // Only heuristics edit bonds during a step: without them the copy leaves out the bond arrays,
  // most of a lattice's state, and the world's state keeps its own. Positions, velocities and the
  // carry-over are never copied: until apply swaps in the step's own they are the ones before the
  // step, and after the swap the scratch's next state and the projection hold those.
  const bool bonds = !last_good_has_bonds_;
  KeptArrays kept(s, bonds);
  if (save)
    last_good_ = s;
  else
    s = last_good_;
  kept.put_back(s, bonds);
  if (applied) {
    s.x.swap(scratch_->next.x);
    s.v.swap(scratch_->next.v);
    s.carry.swap(projection_.carry);
  }
}

}  // namespace qbond
