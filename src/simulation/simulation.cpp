#include "qbond/simulation/simulation.hpp"

#include <stdexcept>
#include <string>

#include "integrators/penalty_contact.hpp"
#include "qbond/analysis/analysis.hpp"
#include "simulation/stages.hpp"

namespace qbond {

namespace {
// Every integrator comes from make_step_integrator: its private paths (advance.hpp).
StepIntegrator& stepper(const std::unique_ptr<Integrator>& integrator) {
  return static_cast<StepIntegrator&>(*integrator);
}

// The integrator holds the model's step contacts: coupled_implicit in its solve, an explicit one as
// penalty forces.
void check_step_contact(const Model& model, IntegratorType type) {
  const ContactMethod method = model.step_contact_method();
  if (method == ContactMethod::implicit && type != IntegratorType::coupled_implicit)
    throw std::invalid_argument("the model's obstacles and quanta contact are held inside the coupled_implicit step's solve, not by " +
                                std::string(to_string(type)) + " (make them penalty or projection rules)");
  if (method == ContactMethod::penalty && !holds_penalty_contact(type))
    throw std::invalid_argument("the model's obstacles and quanta contact are penalty forces of the explicit integrators, not of " +
                                std::string(to_string(type)) + " (make them implicit or projection rules)");
}
}  // namespace

// ---- The step: its stages in order (stages.hpp) -------------------------------------------------

StepReport Simulation::step() {
  // Nothing after the integrator reads dx and dv without heuristics, failing bonds and the
  // ledger: it may then advance the state in place, in its own passes.
  const bool in_place = !edits_bonds() && !ledger_on();
  stage::gather_forces(world_.model, stepper(integrator_), in_place, *scratch_);
  stage::integrate(world_.model, world_.state, stepper(integrator_), h_, limits_.max_speed, ledger_on(), in_place,
                   *scratch_);
  return end_step();
}

void Simulation::begin_step() {
  stage::gather_forces(world_.model, stepper(integrator_), false, *scratch_);
  stage::integrate(world_.model, world_.state, stepper(integrator_), h_, limits_.max_speed, ledger_on(), false,
                   *scratch_);
}

StepReport Simulation::end_step() {
  const Model& m = world_.model;
  State& s = world_.state;
  StepScratch& k = *scratch_;
  const int threads = integrator_->config().threads;
  const bool restore = integrator_->config().restore_energy;
  // The heuristics and the failure of bonds edit the projection or the bonds; the stages around
  // them depend on whether any runs.
  const bool fails = k.bonds_can_fail(s);
  const bool edits = !heuristics_.empty() || fails;
  // Before heuristics and ledger: a rollback undoes both.
  if (keep_last_good_) stage::save_last_good(s, edits, k);
  if (restore) stage::open_books(m, s, threads, k);
  k.quanta_after_valid = false;
  // With heuristics, the integrator's own projection is guarded before they edit it (what they
  // add or take is theirs); without, the step as the ledger charged it.
  StepIntegrator& integrator = stepper(integrator_);
  if (ledger_on() && edits) stage::retake_gaining_projection(m, s, integrator, h_, limits_.max_speed, k);
  for (bool retaken = false;; retaken = true) {
    k.guard_books = s.energy;
    stage::run_heuristics(m, s, heuristics_, threads, k);
    if (fails) stage::break_failed_bonds(m, s, threads, k);
    if (StepReport r = stage::check(m, s, limits_.max_speed, threads, k); r.status != StepReport::Status::ok)
      return roll_back(std::move(r), false);
    if (!ledger_on()) break;
    stage::charge_ledger(m, s, k);
    if (retaken || edits || !stage::retake_gaining_step(m, s, integrator, h_, limits_, k)) break;
  }
  stage::apply(s, k);
  if (restore) stage::restore_energy(m, s, threads, k);
  if (track_energy_) {
    if (StepReport r = stage::check_energy(m, s, limits_, restore, threads, gain_, k);
        r.status != StepReport::Status::ok)
      return roll_back(std::move(r), true);
  }
  stage::observe(m, s, observers_, k);
  return {};
}

bool Simulation::edits_bonds() { return !heuristics_.empty() || scratch_->bonds_can_fail(world_.state); }

StepReport Simulation::roll_back(StepReport r, bool applied) {
  if (!keep_last_good_) return r;
  return stage::roll_back(std::move(r), world_.state, applied, *scratch_);
}

// ---- Setup and state ----------------------------------------------------------------------------

Simulation::Simulation(World world, const IntegratorConfig& config, double h)
    : world_(std::move(world)), integrator_(make_step_integrator(config)), h_(h), scratch_(std::make_unique<StepScratch>()) {
  checked_thread_count(config.threads);  // before any parallel region: OpenMP crashes on absurd counts
  check_step_contact(world_.model, config.type);
  const std::size_t n = world_.num_quanta();
  scratch_->f_ext.assign(n, Vec3::Zero());
  scratch_->f_user.assign(n, Vec3::Zero());
  open_ledger(world_.model, world_.state, world_.state.energy);
}

Simulation::Simulation(Simulation&&) noexcept = default;
Simulation& Simulation::operator=(Simulation&&) noexcept = default;
Simulation::~Simulation() = default;

void Simulation::set_integrator(const IntegratorConfig& config) {
  checked_thread_count(config.threads);
  check_step_contact(world_.model, config.type);
  integrator_ = make_step_integrator(config);
  world_.state.carry = std::monostate{};  // the carry-over was the old integrator's
}

void replace_step_integrator(Simulation& sim, std::unique_ptr<StepIntegrator> integrator) {
  checked_thread_count(integrator->config().threads);
  check_step_contact(sim.world_.model, integrator->config().type);
  sim.integrator_ = std::move(integrator);
  sim.world_.state.carry = std::monostate{};
}

const Adjacency& Simulation::adjacency() { return scratch_->adjacency(world_.model, world_.state); }

const Projection& Simulation::projection() const { return scratch_->projection; }
Projection& Simulation::projection() { return scratch_->projection; }
void Simulation::leave_failures_to_caller() { scratch_->leave_failures = true; }
void Simulation::count_edits_of(std::span<const std::uint8_t> counted) {
  scratch_->counted.assign(counted.begin(), counted.end());
}

const std::vector<BondEvent>& Simulation::events() const { return scratch_->events; }

void Simulation::add_force(Index i, const Vec3& f) {
  scratch_->f_user.at(i) += f;
  scratch_->forces_queued = true;
}

void Simulation::clear_forces() { scratch_->clear_forces(); }

}  // namespace qbond
