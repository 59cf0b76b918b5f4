// RanksRun over MPI: rank 0 runs the ordinary Runner, whose steps are the distributed step and
// whose outputs read the state gathered at each output step; the other ranks take the same steps.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <variant>

#include "distributed/collectives.hpp"
#include "distributed/distributed_step.hpp"
#include "qbond/distributed/distributed.hpp"
#include "qbond/io/checkpoint.hpp"
#include "qbond/io/vtk.hpp"

namespace qbond {

namespace {

// Refuses, with the reason, what a run over ranks does not distribute yet.
void check_distributable(const Scene& scene, int ranks) {
  const std::string over = "a run over " + std::to_string(ranks) + " ranks ";
  const std::string one = "; run it on one rank (without mpirun)";
  const IntegratorType t = scene.integrator.type;
  const bool newton = distributed::newton_integrator(t);
#ifdef QBOND_DISTRIBUTED_IMPLICIT
  const bool implicit = t == IntegratorType::coupled_implicit || newton;
  const char* taken =
      "takes coupled_implicit, energy_momentum, implicit_midpoint, bdf2, hybrid_implicit, velocity_verlet, "
      "symplectic_euler, explicit_euler or rk4, not ";
#else
  const bool implicit = false;
  const char* taken =
      "takes hybrid_implicit, velocity_verlet, symplectic_euler, explicit_euler or rk4 (this qbond was built "
      "without PETSc, which solves coupled_implicit and the Newton integrators over ranks), not ";
#endif
  const bool hybrid = t == IntegratorType::hybrid_implicit;
  if (!implicit && !hybrid && t != IntegratorType::velocity_verlet && t != IntegratorType::explicit_euler &&
      t != IntegratorType::symplectic_euler && t != IntegratorType::rk4)
    throw std::invalid_argument(over + taken + std::string(to_string(t)) + one);
  if (implicit && scene.integrator.solver != CoupledSolver::cg)
    throw std::invalid_argument(over + "solves " + std::string(to_string(t)) +
                                " with PETSc's CG (solver cg), not solver " +
                                std::string(to_string(scene.integrator.solver)) + one);
  // Exact Newton factors the whole Jacobian (sparse LU), which a run over ranks does not.
  if (newton && scene.integrator.newton_polish)
    throw std::invalid_argument(over + "does not polish Newton's steps (newton_polish), which takes exact Newton's "
                                "factorisation of the whole Jacobian" + one);
  // Penalty contacts are forces of the explicit step; obstacles inside coupled_implicit's solve
  // are each owned quanta's; quanta–quanta contact inside it every rank's, in the shell operator's
  // product (hypre's multigrid takes the assembled matrix, which holds the bonds alone).
  const Model& model = scene.world.model;
  if (model.solves_contact() && model.step_contact_method() == ContactMethod::implicit &&
      model.quanta_contact.radius > 0 && scene.integrator.preconditioner == Preconditioner::multigrid)
    throw std::invalid_argument(over + "solves quanta contact inside the implicit step (\"method\": \"implicit\") "
                                "with the block-Jacobi CG, not preconditioner multigrid (hypre's, on the assembled "
                                "matrix, which holds no contacts)" + one);
  // After each step and in this order: obstacles, quanta contact and damping zones as projection
  // rules (an obstacle's or zone's edit of a quanta its own, on its owner's piece; the contacts'
  // passes over every quanta in contact, on every rank); plasticity and fracture (each bond
  // flowed and tested by one rank at the step's end positions, so after the rules' edits, the
  // stress limits reading each end's stress from its owner); formation (every rank forming the
  // bonds among the quanta near others, after the breaks).
  int stage = 0;  // 0 projection rules, 1 plastic, 2 break, 3 form rules, as far as the list has come
  const char* order = "over ranks the heuristics take effect in this order: obstacles, contact and damping zones, "
                      "'plastic', 'break', 'form'; list them so in \"heuristics\"";
  for (const HeuristicSpec& spec : scene.heuristics) {
    const int at = std::holds_alternative<PlasticRule>(spec) ? 1
                   : std::holds_alternative<BreakRule>(spec) ? 2
                   : std::holds_alternative<FormRule>(spec)  ? 3
                                                             : 0;
    if (at < stage) throw std::invalid_argument(over + "cannot keep the run alone's order: " + order + one);
    stage = at;
  }
  // Bonds that fail at their law's stretch break after the break rules, as alone; the run alone
  // tests them after its form rules too, which over ranks follow the breaks.
  const Bonds& b = scene.world.state.bonds;
  for (std::size_t k = 0; k < b.size(); ++k)
    if (law_breaks(b.law[k]) && stage == 3)
      throw std::invalid_argument(over + "does not distribute bonds that break at their law's failure stretch (" +
                                  std::string(to_string(b.law[k])) + ") beside 'form' rules yet" + one);
  // The gain and an adaptive step's energy drift are judged before the step's breaks are shared,
  // while the step can still be undone: formed bonds and the restoration change the energy after that.
  bool forms = false;
  for (const HeuristicSpec& spec : scene.heuristics) forms = forms || std::holds_alternative<FormRule>(spec);
  const char* later = " beside 'form' rules or restore_energy, which change the energy after the step can be undone";
  if (scene.limits.stop_on_energy_gain && (forms || scene.integrator.restore_energy))
    throw std::invalid_argument(over + "does not stop on the energy gained (stop_on_energy_gain)" + later + one);
  if (scene.adaptive.enabled && (forms || scene.integrator.restore_energy))
    throw std::invalid_argument(over + "does not adapt its step" + later + one);
}

}  // namespace

struct RanksRun::Impl {
  Scene scene;  // the other ranks' (rank 0's Runner holds its own)
  RunSettings settings;
  std::unique_ptr<distributed::DistributedStep> dist;
  std::optional<Runner> runner;  // rank 0
  std::function<bool()> stop;
  RanksStats stats;
  bool pieces = false;  // frames as .pvtp files, one piece per rank

  // A frame's piece of this rank: frames/frame_<step>_<rank>.vtp.
  static std::string piece_name(std::uint64_t step, int rank) {
    const std::string f = frame_file(step, "vtp");
    return f.substr(0, f.size() - 4) + "_" + std::to_string(rank) + ".vtp";
  }
  // This rank's piece of the current state's frame (the other ranks' ranks; rank 0 writes its own
  // with the .pvtp, from its Runner's outputs, at the same steps).
  void write_piece() const { dist->write_piece(settings.out_dir / piece_name(dist->step_count(), mpi_rank())); }
  // Rank 0's frame: its piece and the .pvtp that lists every rank's.
  void write_frame(const std::filesystem::path& file) const {
    std::vector<std::string> names;
    for (int k = 0; k < mpi_ranks(); ++k)
      names.push_back(std::filesystem::path(piece_name(dist->step_count(), k)).filename().string());
    dist->write_piece(file.parent_path() / names[0]);
    write_pvtp(file, names);
  }

  // The ranks' counts into `stats` on rank 0 (collective).
  void gather_stats() {
    const distributed::DistributedStep::Times& t = dist->times();
    const double mine[6] = {static_cast<double>(dist->owned_quanta()), static_cast<double>(dist->ghost_quanta()),
                            8.0 * static_cast<double>(dist->doubles_sent()), t.stepping, t.bookkeeping, t.wall};
    const std::vector<double> all = distributed::gather_to_root(mine);
    stats.ranks = mpi_ranks();
    stats.migrations = dist->migrations();
    stats.recuts = dist->recuts();
    stats.halo_rebuilds = dist->halo_rebuilds();
    stats.retakes = dist->retakes();
    stats.halved = dist->halved();
    stats.steps = t.steps;
    for (std::size_t k = 0; k + 6 <= all.size(); k += 6) {
      stats.owned.push_back(static_cast<std::size_t>(all[k]));
      stats.ghosts.push_back(static_cast<std::size_t>(all[k + 1]));
      stats.bytes_sent.push_back(all[k + 2]);
      stats.stepping.push_back(all[k + 3]);
      stats.bookkeeping.push_back(all[k + 4]);
      stats.wall.push_back(all[k + 5]);
    }
  }

  // Whether the step just taken is one whose state rank 0 writes (a row, a frame, a checkpoint,
  // the run's end): every rank decides alike, and then takes part in the gather.
  bool due(const StepReport& r) const {
    const std::uint64_t s = dist->step_count();
    return r.status != StepReport::Status::ok || dist->stop_agreed() || s % settings.every == 0 ||
           (settings.checkpoint_every && s % settings.checkpoint_every == 0) || finished();
  }
  // Whether the run has come to its end, as the Runner's: a time with adaptive steps, else a step.
  bool finished() const {
    return adaptive ? dist->time() >= end_time : dist->step_count() >= settings.steps;
  }
  bool adaptive = false;
  double end_time = 0;  // [s]

  // Splits `scene` over the ranks (refusing what is not distributed; a resumed run over as many
  // ranks as its checkpoint's cut as it was) and, on rank 0, starts the outputs with make_runner
  // (a new run or a resumed one), which gives its settings the ranks' outputs (`outfit`): the
  // frame writer when the ranks write pieces, the boxes for its checkpoints.
  using Outfit = std::function<void(RunSettings&)>;
  void start(Scene scene, RunSettings run_settings, bool resumed,
             const std::function<Runner(Scene, RunSettings, const Outfit&)>& make_runner);

  // One step, and the gather when it is due, into `world` (rank 0's outputs read it).
  StepReport step(World& world) {
    StepReport r = dist->step(stop && stop());
    dist->apply_events(world);  // before its time moves on: a broken bond records the step's start
    // The other ranks' pieces of the frames rank 0's Runner writes on its schedule.
    if (pieces && !runner && r.status == StepReport::Status::ok && dist->step_count() % settings.every == 0)
      write_piece();
    if (due(r)) {
      dist->gather(world);
    } else {
      world.state.step = dist->step_count();
      world.state.time = dist->time();
    }
    return r;
  }
};

RanksRun::RanksRun(Scene scene, RunSettings settings) : impl_(std::make_unique<Impl>()) {
  impl_->start(std::move(scene), std::move(settings), false, [](Scene s, RunSettings rs, const Impl::Outfit& outfit) {
    outfit(rs);
    return Runner(std::move(s), std::move(rs));
  });
}

RanksRun::RanksRun(const std::filesystem::path& checkpoint, const std::function<void(Scene&, RunSettings&)>& adjust,
                   std::uint64_t max_memory)
    : impl_(std::make_unique<Impl>()) {
  // Every rank reads the checkpoint (the whole state, whatever the rank count that wrote it);
  // rank 0 resumes its outputs in its directory.
  auto [scene, settings] = Runner::read_checkpoint(checkpoint, adjust, max_memory);
  if (!settings.resumed_ranks.empty()) {
    try {
      distributed::Strays strays;
      (void)distributed::bisection_from_json(settings.resumed_ranks, &strays);
      for (const auto& [q, part] : strays)
        if (q >= scene.world.num_quanta())
          throw std::invalid_argument("ranks: strays: quanta " + std::to_string(q) + " of a world of " +
                                      std::to_string(scene.world.num_quanta()));
    } catch (const std::invalid_argument& e) {
      throw CheckpointError(checkpoint.string() + ": metadata: " + e.what());
    }
  }
  impl_->start(std::move(scene), std::move(settings), true, [&](Scene, RunSettings, const Impl::Outfit& outfit) {
    return Runner::resume(
        checkpoint,
        [&](Scene& s, RunSettings& rs) {
          if (adjust) adjust(s, rs);
          outfit(rs);
        },
        max_memory);
  });
}

void RanksRun::Impl::start(Scene scene, RunSettings run_settings, bool resumed,
                           const std::function<Runner(Scene, RunSettings, const Outfit&)>& make_runner) {
  Impl& r = *this;
  const int ranks = mpi_ranks();
  r.pieces = ranks > 1 && run_settings.frame_pieces && run_settings.vtk;
  const Outfit outfit = [&r](RunSettings& rs) {
    if (r.pieces) rs.write_frame = [&r](const std::filesystem::path& file) { r.write_frame(file); };
    // At a checkpoint rank 0's world holds the whole state, gathered for it.
    if (r.dist) rs.ranks_layout = [&r] { return r.dist->layout(r.runner->simulation().world().state.x); };
  };
  if (ranks > 1) {
    check_distributable(scene, ranks);
    // The ranks charge the ledger themselves, over their own bonds (distributed_step.cpp).
    if (!run_settings.ledger) throw std::invalid_argument("--no-ledger: not over MPI ranks (run it alone)");
    if (run_settings.every == 0) throw std::invalid_argument("output interval must be >= 1 step");
    // Ranks on one machine share its cores: each takes its share unless told (OMP_NUM_THREADS).
    const int on_node = distributed::ranks_on_this_node();
    if (scene.integrator.threads == 0 && !std::getenv("OMP_NUM_THREADS"))
      scene.integrator.threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / on_node);
    r.dist = std::make_unique<distributed::DistributedStep>(scene.world, scene.integrator, scene.timestep,
                                                            scene.limits);
    if (scene.adaptive.enabled) {
      // As the Runner alone: the run ends at steps × timestep; a resumed one goes on from its
      // controller's state.
      r.adaptive = true;
      r.end_time = static_cast<double>(run_settings.steps) * scene.timestep;
      const bool held = run_settings.resumed_next_step > 0;
      r.dist->set_adaptive(scene.adaptive, r.end_time, held ? run_settings.resumed_next_step : scene.timestep,
                           held ? run_settings.resumed_last_step : scene.timestep);
    }
    if (resumed && !run_settings.resumed_ranks.empty()) {
      distributed::Strays strays;
      distributed::Bisection cuts = distributed::bisection_from_json(run_settings.resumed_ranks, &strays);
      if (cuts.parts == ranks) r.dist->take_cuts(std::move(cuts), strays);
    }
    std::vector<BreakRule> rules;
    std::vector<PlasticRule> plastic;
    std::vector<distributed::ProjectionRule> projection;
    std::vector<FormRule> forms;
    for (const HeuristicSpec& spec : scene.heuristics) {
      if (const auto* o = std::get_if<Obstacle>(&spec)) projection.emplace_back(*o);
      else if (const auto* c = std::get_if<QuantaContactRule>(&spec)) projection.emplace_back(*c);
      else if (const auto* z = std::get_if<DampingZone>(&spec)) projection.emplace_back(*z);
      else if (const auto* f = std::get_if<FormRule>(&spec)) forms.push_back(*f);
      else if (const auto* p = std::get_if<PlasticRule>(&spec)) plastic.push_back(*p);
      else rules.push_back(std::get<BreakRule>(spec));
    }
    if (!projection.empty()) r.dist->set_projection_rules(std::move(projection));
    if (!forms.empty()) r.dist->set_form_rules(std::move(forms));
    if (!plastic.empty()) r.dist->set_plastic_rules(std::move(plastic));
    if (!rules.empty()) r.dist->set_break_rules(std::move(rules));
  }
  r.settings = run_settings;
  // Rank 0 claims the output directory; should that fail, every rank stops with it.
  int failed[1] = {0};
  if (mpi_rank() == 0) {
    try {
      r.runner.emplace(make_runner(std::move(scene), std::move(run_settings), outfit));
    } catch (const std::exception&) {
      failed[0] = 1;
      if (ranks > 1) distributed::max_over_ranks(failed);
      throw;
    }
  } else {
    r.scene = std::move(scene);
  }
  if (ranks > 1) {
    distributed::max_over_ranks(failed);
    if (failed[0]) throw std::runtime_error("rank 0 could not start the run's outputs");
  }
  // A new run's first frame, which rank 0's Runner has written (after it cleared the directory).
  if (r.pieces && !r.runner && !resumed) r.write_piece();
  if (r.runner && r.dist) {
    r.runner->set_stepper({.step = [&r] { return r.step(r.runner->simulation().world()); },
                           .events = [&r]() -> const std::vector<BondEvent>& { return r.dist->events(); },
                           .stats = [&r] { return r.dist->solve_stats(); },
                           .energy_gain = [&r]() -> const EnergyGain& { return r.dist->energy_gain(); },
                           .steps = [&r] { return std::pair(r.dist->last_step(), r.dist->next_step()); }});
  }
}

RanksRun::~RanksRun() = default;

RunResult RanksRun::run(const std::function<bool()>& stop, const std::function<void(const RunProgress&)>& progress) {
  Impl& r = *impl_;
  if (!r.dist) return r.runner->run(stop, progress);  // one rank: the ordinary run
  r.stop = stop;
  try {
    if (r.runner) {
      const RunResult result = r.runner->run([&r] { return r.dist->stop_agreed(); }, progress);
      r.gather_stats();
      return result;
    }
    const auto t0 = std::chrono::steady_clock::now();
    RunResult result;
    const std::uint64_t start = r.dist->step_count();
    while (!r.finished()) {
      const StepReport rep = r.step(r.scene.world);
      if (rep.status != StepReport::Status::ok) {
        result.status = RunStatus::blowup;
        result.message = rep.message;
        break;
      }
      if (r.dist->stop_agreed() && !r.finished()) {
        result.status = RunStatus::stopped;
        break;
      }
    }
    // The frame rank 0 writes at the run's end, when not on the schedule.
    if (r.pieces && r.dist->step_count() % r.settings.every != 0) r.write_piece();
    result.steps_taken = r.dist->step_count() - start;
    result.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    r.gather_stats();
    return result;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "qbond: rank %d of %d: %s\n", mpi_rank(), mpi_ranks(), e.what());
    distributed::abort_job(1);
  }
}

const RanksStats& RanksRun::stats() const { return impl_->stats; }
const World& RanksRun::world() const { return impl_->runner ? impl_->runner->simulation().world() : impl_->scene.world; }
const Scene& RanksRun::scene() const { return impl_->runner ? impl_->runner->scene() : impl_->scene; }
const RunSettings& RanksRun::settings() const { return impl_->runner ? impl_->runner->settings() : impl_->settings; }

}  // namespace qbond
