#pragma once
/// The step pipeline, as named stages: gather external forces → integrate →
/// heuristics → check → energy ledger (optional) → apply → observers (src/simulation/stages.hpp,
/// one file each). Same inputs, same bits: nothing here depends on timing or thread count.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "qbond/heuristics/heuristics.hpp"
#include "qbond/integrators/integrators.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

struct StepScratch;  // what the stages hand each other, and their buffers (src/simulation/)

/// Limits past which a step counts as a blow-up.
struct BlowupLimits {
  double max_speed = 1e5;  ///< [m/s] any free quanta faster than this
  /// Kinetic + bond energy may not exceed this factor times the energy the system could have
  /// gained (initial kinetic + bond energy + |gravity work| + |load and anchor work|).
  double energy_growth = 1e3;
  double energy_floor = 1e-9;  ///< [J] absolute slack so that systems at rest don't trip it
  /// Energy gained: E(t) − E(0) − (loads' + anchors' work) above this fraction of what the system
  /// could hold without gaining (as for energy_growth, less the factor) is reported
  /// (Simulation::energy_gain) and, with stop_on_energy_gain, ends the run like a blow-up.
  double energy_gain = 0.01;
  bool stop_on_energy_gain = false;
};

/// The largest energy gain of a run beyond the work done on it (BlowupLimits::energy_gain).
struct EnergyGain {
  double largest = 0;           ///< largest E(t) − E(0) − work seen [J]
  double relative = 0;          ///< the same over what the system could hold then
  bool exceeded = false;        ///< relative went above BlowupLimits::energy_gain
  std::uint64_t first_step = 0; ///< the step at which it first did
  double first_time = 0;        ///< [s]
};

/// Outcome of one step.
struct StepReport {
  enum class Status { ok, blowup } status = Status::ok;
  std::string message;      ///< set on blow-up: what, where and when
  Index worst = 0;          ///< quanta with the worst value on blow-up (its index; the message
                            ///< names its user id, Model::quanta_id)
};

/// Something that looks at the world after every applied step (diagnostics, outputs, viewer).
class Observer {
 public:
  virtual ~Observer() = default;
  virtual void observe(const Model& model, const State& state, const StepContext& ctx) = 0;
};

/// A world, the integrator that steps it, its heuristics and observers.
class Simulation {
 public:
  Simulation(World world, const IntegratorConfig& config, double h);
  Simulation(Simulation&&) noexcept;
  Simulation& operator=(Simulation&&) noexcept;
  ~Simulation();

  /// One whole step. On blow-up the world keeps the last good state when the projection
  /// itself is bad (non-finite or too fast); an energy runaway is caught right after applying,
  /// and rolled back too when set_keep_last_good(true).
  StepReport step();
  /// Split step for interactive use: `begin_step` gathers forces and projects; the caller may
  /// add forces before it or edit the projection after it; `end_step` runs heuristics, applies,
  /// checks and notifies observers.
  void begin_step();
  StepReport end_step();

  /// Adds a force [N] to quanta i for the next step only (viewer drags, scripted pushes).
  void add_force(Index i, const Vec3& f);
  /// Drops the forces add_force queued for the next step (a step retried re-queues them).
  void clear_forces();
  /// Appends a heuristic to the ordered list (before the run: it may add law shapes to the model,
  /// Heuristic::bind).
  void add_heuristic(std::unique_ptr<Heuristic> h) {
    h->bind(world_.model);
    heuristics_.push_back(std::move(h));
  }
  /// Makes the step leave bonds past their law's failure stretch unbroken: the caller breaks them
  /// (a piece of a run over ranks, whose ranks decide each bond once).
  void leave_failures_to_caller();
  /// The quanta whose heuristic edits the books charge (HeuristicContext::counted; empty: all).
  void count_edits_of(std::span<const std::uint8_t> counted);
  /// Removes every heuristic (a viewer turning them off).
  void clear_heuristics() { heuristics_.clear(); }
  void add_observer(Observer* o) { observers_.push_back(o); }
  /// Replaces the integrator (keeps the world, drops the old one's carry-over, State::carry).
  void set_integrator(const IntegratorConfig& config);
  /// Makes the next step a function of the State alone (Integrator::forget_history): called
  /// where a checkpoint is written or restored, so that a resumed run continues bit for bit.
  void forget_history() { integrator_->forget_history(); }
  /// The library's own path to an integrator that make_integrator does not build (internal).
  friend void replace_step_integrator(Simulation& sim, std::unique_ptr<StepIntegrator> integrator);

  World& world() { return world_; }
  const World& world() const { return world_; }
  const Integrator& integrator() const { return *integrator_; }
  /// The last projection: dx and dv after begin_step; after step() with no heuristic and no
  /// energy ledger they may be empty, the integrator having written the state to apply instead.
  const Projection& projection() const;
  /// The projection between begin_step and end_step, for the caller to edit.
  Projection& projection();
  /// Topology changes the heuristics made during the last step (cleared when a step begins).
  const std::vector<BondEvent>& events() const;
  double timestep() const { return h_; }
  void set_timestep(double h) { h_ = h; }
  BlowupLimits& limits() { return limits_; }
  /// The largest energy gain beyond external work since this Simulation was made (checked every
  /// step with the energy ledger on).
  const EnergyGain& energy_gain() const { return gain_; }
  /// Whether the energy ledger is updated, and checked for a runaway, every step (costs one pass
  /// over the bonds).
  void set_track_energy(bool on) { track_energy_ = on; }
  /// Whether each step first copies the state so that an energy runaway, found only after the
  /// step applied, can be undone (costs one copy per step of the state's small fields, and of its
  /// bond arrays when a heuristic is on or a bond's law can fail: positions and velocities are kept by the step's own
  /// swap; runs that save the last good state on blow-up turn it on).
  void set_keep_last_good(bool on) { keep_last_good_ = on; }
  const Adjacency& adjacency();

 private:
  bool ledger_on() const { return track_energy_ || integrator_->config().restore_energy; }
  /// Whether a stage after the integrator edits the bonds: a heuristic, or the failure of bonds
  /// whose law breaks them (a cohesive bond at its failure stretch).
  bool edits_bonds();
  /// The report, with the state before the step put back when set_keep_last_good(true).
  StepReport roll_back(StepReport r, bool applied);

  World world_;
  std::unique_ptr<Integrator> integrator_;  // make_step_integrator's: simulation.cpp's stepper()
  std::vector<std::unique_ptr<Heuristic>> heuristics_;
  std::vector<Observer*> observers_;
  double h_;
  BlowupLimits limits_;
  EnergyGain gain_;
  bool track_energy_ = true;
  bool keep_last_good_ = false;
  std::unique_ptr<StepScratch> scratch_;
};

}  // namespace qbond
