#pragma once
// The step of a run over ranks: every rank advances its piece of the world (local_world.hpp) with
// the ordinary step, then the ranks exchange their ghosts' new state (halo.hpp), charge the energy
// ledger for the bonds each owns, and move quanta that left their rank's box to their new owner.
// Every rank calls every member at the same point of the run (they are collective).
#include <filesystem>
#include <memory>
#include <optional>
#include <variant>
#include <vector>

#include "distributed/coupled_over_ranks.hpp"
#include "distributed/halo.hpp"
#include "distributed/local_world.hpp"
#include "distributed/partition.hpp"
#include "heuristics/break_criteria.hpp"
#include "heuristics/contact_ranks.hpp"
#include "heuristics/formation_pass.hpp"
#include "heuristics/plastic_flow.hpp"
#include "integrators/energy_restore.hpp"
#include "integrators/penalty_contact.hpp"
#include "integrators/ranks_link.hpp"
#include "ledger/step_work.hpp"
#include "qbond/analysis/analysis.hpp"
#include "qbond/heuristics/damping_zone.hpp"
#include "qbond/integrators/adaptive.hpp"
#include "qbond/simulation/simulation.hpp"
#include "solvers/coloring.hpp"

namespace qbond::distributed {

// The kind of carry-over the pieces' steps hold (every rank's the same): velocity Verlet's
// forces, a solve's guess or guesses with the lengths of the steps they were taken over, or none.
struct CarryKind {
  enum class Kind : std::uint8_t { none, forces, guess, guesses, history } kind = Kind::none;
  double h = 0, h_before = 0;  // guesses: the steps' lengths; history: the step's
  double t = 0;                // history: the time of its state
  std::uint64_t step = 0;      // history: the index of its step
};

// A heuristic that edits the projected step, distributed: an obstacle, quanta contact or a
// damping zone.
using ProjectionRule = std::variant<Obstacle, QuantaContactRule, DampingZone>;

// Whether `t` is a Newton integrator (newton.hpp), whose iterations a run over ranks links and
// whose linear solves go over the ranks.
inline bool newton_integrator(IntegratorType t) {
  return t == IntegratorType::energy_momentum || t == IntegratorType::implicit_midpoint || t == IntegratorType::bdf2;
}

class DistributedStep final : private RanksLink, private ContactRanks {
 public:
  // Splits `whole` (the same on every rank) over the job's ranks; config.type must be an explicit
  // integrator (velocity_verlet, explicit_euler, symplectic_euler, rk4), with the model's penalty
  // contacts if any, hybrid_implicit, or, built with PETSc, coupled_implicit with the cg solver
  // and no quanta–quanta contact in its solve (the caller checks). What the steps carry (velocity Verlet's
  // forces, a solve's guesses) comes from whole.state.carry when it holds it; velocity Verlet's
  // forces are else evaluated once here. Throws when a solve over ranks would leave a rank
  // without quanta.
  DistributedStep(const World& whole, const IntegratorConfig& config, double h, const BlowupLimits& limits);
  ~DistributedStep();
  DistributedStep(const DistributedStep&) = delete;  // the pieces' integrators link to it
  DistributedStep& operator=(const DistributedStep&) = delete;

  // One step on every rank. `stop`: this rank asks that the run stop after it (stop_agreed()). On
  // a blow-up on any rank every rank keeps the state before the step and returns the report of
  // the first rank that found one (its quanta as a whole-world index).
  StepReport step(bool stop);
  // The boxes the ranks hold and the quanta owned outside theirs at positions x (the whole
  // state now: bisection_json with its strays), for a checkpoint.
  std::string layout(std::span<const Vec3> x) const;
  // Cuts the world as `cuts` does (a checkpoint's, over as many ranks), gives the strays to
  // their owners and builds the pieces anew: a resumed run then takes the uninterrupted run's
  // pieces and sums. Each stray must be a quanta of the world.
  void take_cuts(Bisection cuts, const Strays& strays);
  // Whether some rank asked, during the last step, that the run stop.
  bool stop_agreed() const { return stop_agreed_; }
  // The whole state on rank 0, into `into` (a world of the same quanta and bonds): positions,
  // velocities, time, step, velocity Verlet's carried forces, and the ledger's work of anchors,
  // dampers and loads. Throws when a quanta is missing or held twice.
  void gather(World& into);

  // Fracture over ranks: break rules, in the scene's order. After each step every rank tests the
  // bonds it owns (those whose first end it owns) at the step's end positions, each bond once
  // over the ranks (the stress limits with each end's virial stress from the piece that owns it);
  // rules with a probability below 1 gather the bonds over a threshold and every rank draws for
  // them in the whole world's bond order from the same generator, as a run on one rank draws.
  // The breaks are then shared, so that every rank's topology stays the same.
  void set_break_rules(std::vector<BreakRule> rules);
  // Plasticity over ranks: plastic rules (after the projection rules, before the break rules), in
  // the scene's order. After each step every rank flows the bonds it owns at the step's end
  // positions (PlasticFlow) and breaks those past their ductility limit; the new rest lengths are
  // then shared, so that every piece holding a bond holds its rest length, and velocity Verlet's
  // forces are evaluated afresh after a step that flowed any bond, as the run alone's are.
  void set_plastic_rules(std::vector<PlasticRule> rules);
  // Formation over ranks: form rules (after the break rules and the projection rules), in the
  // scene's order. After each step's breaks each rank sends its owned quanta that lie within a
  // capture radius of another (its piece holds every quanta that near, as for quanta contact),
  // and every rank forms the whole world's bonds among them as the run alone's rules do, in the
  // whole world's order; the pieces are then built anew.
  void set_form_rules(std::vector<FormRule> rules);
  // Obstacles, quanta contact and damping zones as projection rules (one heuristic each, in the
  // scene's order, before the plastic and break rules): every piece edits its quanta's projection after the ghosts' rows
  // came from their owners, so that an owned quanta's edit and its bonds' energy read the run
  // alone's numbers; the books and the obstacles' impulses count the owned quanta and bonds
  // alone. Quanta contact projects the whole world's pairs on every rank (contact_ranks.hpp),
  // each piece holding as ghosts the quanta its own can touch (as for penalty contact). Velocity
  // Verlet's forces after a step that any rank edited are evaluated afresh by their owners, as
  // the run alone evaluates them when the state is not the one its carried forces were left for.
  void set_projection_rules(std::vector<ProjectionRule> rules);
  // Adaptive steps over ranks, with the run alone's controller (adaptive_step): each step is
  // tried from the proposal until accepted, ending exactly at t_end; the error estimate is the
  // largest over every rank's owned quanta, and the energy drift is the change of the books summed
  // over the ranks less the energy's. `proposal`: the first try's length [s]; `last`: the step
  // that led to the current state [s].
  void set_adaptive(const AdaptiveConfig& config, double t_end, double proposal, double last);
  // The step that led to the current state and the one the next step tries first [s] (both the
  // timestep without adaptive steps).
  double last_step() const { return last_h_; }
  double next_step() const { return adaptive_ ? proposal_ : h_; }
  // The last step's solve as this rank's piece took it (the solves over ranks' iterations and
  // residual are the whole system's, the same on every rank); empty on a rank without quanta.
  const SolveStats& solve_stats() const { return solve_stats_; }
  /// E(t) − E(0) beyond the external work so far, as Simulation::energy_gain records it.
  const EnergyGain& energy_gain() const { return gain_; }
  // The bonds the last step broke and formed (whole-world indices), in the order a run on one rank records them.
  const std::vector<BondEvent>& events() const { return events_; }
  // Breaks and forms the last step's bonds in `w` (a world of the same quanta and bonds), called
  // before its time moves on to the step's end (a bond records the step's start, as on one rank).
  void apply_events(World& w) const;

  // Writes this rank's piece of a frame (write_vtp_piece): the quanta it owns and the bonds whose
  // first end it owns, each quanta and bond in exactly one rank's piece, at the current state.
  void write_piece(const std::filesystem::path& file) const;

  // The step count and time every rank agrees on.
  std::uint64_t step_count() const { return whole_.state.step; }
  double time() const { return whole_.state.time; }
  // Quanta this rank owns, the ghosts it holds, and how often quanta moved between ranks.
  std::size_t owned_quanta() const { return owned_.size(); }
  std::size_t ghost_quanta() const { return global_.size() - owned_.size(); }
  std::uint64_t migrations() const { return migrations_; }
  // How often the boxes were cut anew because the ranks' loads drifted apart.
  std::uint64_t recuts() const { return recuts_; }
  // With quanta contact: how often the pieces were built anew for their contact halos, and how
  // often a step was taken again because a quanta had moved past its halo in it.
  std::uint64_t halo_rebuilds() const { return halo_rebuilds_; }
  std::uint64_t retakes() const { return retakes_; }
  // coupled_implicit: how often the energy guard took a step again in halves.
  std::uint64_t halved() const { return halved_; }
  // Doubles this rank has sent in ghost exchanges.
  std::size_t doubles_sent() const { return halo_.doubles_sent(); }
  // Where this rank's time went over the steps taken: the CPU time of its own step (the piece's
  // step, and the check for quanta that left the box) and of its bookkeeping (ledger and energy
  // sums), and the wall time of whole steps, exchanges and waits included [s].
  struct Times {
    double stepping = 0, bookkeeping = 0, wall = 0;
    std::uint64_t steps = 0;
  };
  const Times& times() const { return times_; }

 private:
  // step() but for its timing (cpu0: the CPU time when the step began); `retaken`: the step is
  // taken again from pieces built anew, after a quanta moved past the contact halo in it.
  StepReport step_timed(bool stop, double cpu0, bool retaken = false);
  // step() with adaptive steps (set_adaptive): tries until one is accepted, or one at min_step.
  StepReport adaptive_step(bool stop);
  // Adaptive steps: whether the try's error estimate, the largest over the ranks, rejects it
  // before the pieces finish their steps (collective).
  bool rejects_error();
  // Adaptive steps: whether the step just taken, from energies e_before (the step's start) to
  // `after` with the books then `books`, drifts past the controller's bound; the controller then
  // shortens the next try.
  bool drifted(double e_before, const Energies& after, double books);
  // The quanta pairs the pieces' contact halos hold, from the whole state (none without quanta contact).
  ContactHalo contact_halo() const;
  // Builds this rank's piece from whole_ and owner_ with what the whole world's step carries
  // (`carried`: kCarried numbers a quanta by whole index, of `kind`: velocity Verlet's forces or
  // the solve's guesses); when null, velocity Verlet's forces evaluated here and exchanged, and
  // no guess.
  void build(const std::vector<double>* carried, const CarryKind& kind);
  // The ghosts' positions and velocities (and carried forces) from their owners.
  void exchange_ghosts();
  // The piece's step (of its timestep); with projection rules, the ghosts' projection rows come
  // from their owners before the rules edit it.
  StepReport piece_step();
  // Whether the piece takes its step whole (Simulation::step, which may advance in place): no
  // projection rules edit its projection and no adaptive try reads it first.
  bool whole_piece() const { return projection_rules_.empty() && !adaptive_; }
  // Velocity Verlet's forces a(x, v) at the piece's state w, kCarried numbers a quanta: the
  // owned quanta's evaluated here (the piece holds all their bonds), the ghosts' from their owners.
  std::vector<double> fresh_forces(const World& w);
  // coupled_implicit with projection rules: whether the piece's projection, before the rules
  // edit it, creates energy, judged over every rank as the run alone's guard judges it (gains).
  bool projection_gains();
  // The loads' work on the owned quanta over displacements dx: each load's share times a quanta's
  // displacement, as step_work charges it on one rank [J].
  double owned_loads_work(const Model& m, const std::vector<Vec3>& dx) const;
  // Whether the projection rules edited an owned quanta in the last step: its state is not the
  // one velocity Verlet's carried forces were left for.
  bool edited() const;
  // The anchors' and dampers' work over the owned bonds and the loads' on the owned quanta, from
  // the state before the step (of length H); returns the step's work and the owned bonds' energy
  // after it [J].
  StepWork charge_ledger(double H);
  // What every rank decides after a step, from one all-gather: a blow-up (the first refusal of a
  // piece's own step check, by rank, else the energy runaway check of a run on one rank,
  // Simulation's check_energy, over every rank's quanta and bonds), whether quanta left their
  // boxes, whether a stop was asked for.
  // With penalty contacts, the step's contact books added over the ranks, and the farthest any
  // quanta has moved since the pieces were built; the energies after the step and the step's
  // work and dampers' loss over every rank, for the energy guard.
  struct Verdict {
    StepReport report;
    bool migrate = false, stop = false;
    Projection::ContactEnergy contact;
    double moved = 0;  // [m]
    Energies after;
    double work = 0, damping = 0;  // [J]
    double released = 0;  // what the step's breaks took out of its state [J]
    bool edited = false;  // the projection rules edited some rank's quanta (velocity Verlet)
    // E(t) − E(0) beyond the external work, and what the system could hold (check_energy's) [J].
    double gain = 0, available = 0;
  };
  // `released`: the energy of the bonds this rank broke in the step [J].
  Verdict agree(const StepReport& report, bool left, bool stop, const StepWork& work, double contact_after,
                double released) const;
  // coupled_implicit: whether the step the verdict judges created energy beyond its books, as the
  // run alone's energy guard decides, on the state before its breaks, the solved contacts' work
  // credited: a whole step (retake_gaining_step: of a run without heuristics with its dampers'
  // loss credited and the energy floor), the projection before the heuristics
  // (retake_gaining_projection), both kept with friction in the contacts, or a half of a step
  // taken in halves (the coupled step's substeps).
  enum class Guard : std::uint8_t { step, projection, half };
  bool gains(const Verdict& v, Guard guard) const;
  // The run alone's record of the energy gained (stage::record_gain) at the end of the step the
  // verdict judged, whose bonds' energy then changed by `bonds` (formed less broken after it);
  // with limits.stop_on_energy_gain, the report that stops the run when the gain is past it.
  StepReport record_gain(const Verdict& v, double bonds);
  // A report of a step undone, saying so as the run alone's does.
  static StepReport kept_before(StepReport r);
  // The whole run's books over every rank: the external work less what the dampers, heuristics
  // and contacts took out and what the contacts' springs hold [J] (collective).
  double net_books() { return net_books(0, contact_dissipated_, contact_stored_); }
  // The same with this rank's `pending` heuristics' loss not yet in heuristics_loss_ and the
  // contacts' books as given [J] (collective).
  double net_books(double pending, double contact_dissipated, double contact_stored);
  // restore_energy over the ranks (scale_internal_velocities, each rank scaling its owned quanta,
  // the whole world's components summed over the ranks), after the step's breaks and forms, its
  // energy then energy_start_: E(end) made E(start) plus the step's change of net_books(), as
  // the run alone's stage::restore_energy does. Returns the kinetic energy added, the same on
  // every rank, and adds it to energy_start_ (collective).
  double restore_energy(double e_start);
  // The step just undone, taken again as two halves: coupled_implicit's each again in halves
  // while it creates energy, as the run alone's energy guard takes it; energy_momentum's and
  // implicit_midpoint's while Newton's iteration does not converge, as their integrator alone
  // takes it; breaks decided after the last half (collective). cpu0: the CPU time when the
  // halves began.
  StepReport split_step(bool stop, double cpu0);
  // Whether the piece's Newton step (energy_momentum, implicit_midpoint) did not converge, which
  // the run alone takes again in halves (collective).
  bool newton_unconverged();
  // One substep [t_a, t_b] of split_step from the state the pieces hold, split again while it
  // creates energy (a Newton half: does not converge), to its integrator's depth: false, the
  // pieces back at t_a, when it blew up.
  bool half(double t_a, double t_b, int depth, bool stop, Verdict& last);
  // The counted springs' energy of the penalty contacts at the step's end, from the exchanged
  // state (a ghost's end in the piece's own step lacks its bonds and contacts off the piece) [J].
  double contact_stored_after();
  // This piece back to the state before the step, its ledger charges `work` taken back.
  void roll_back(const StepWork& work);
  // Whether a step the pieces took may still be undone (an adaptive try, stop_on_energy_gain, a
  // retake for quanta contact): the pieces then keep what their step carried in (carry0_), for
  // the run alone's undo restores it (velocity Verlet's damped forces a(x, ṽ) are not a(x, v)).
  bool undoable() const { return try_ || limits_.stop_on_energy_gain || reach_ > 0; }
  // The piece's carry-over back to carry0_, when kept.
  void restore_carry();
  // Every piece rebuilt from the state the ranks hold (after roll_back), with what the step
  // carried in when restore_carry kept it, else fresh carried forces.
  void rebuild_after_roll_back();
  // Every piece rebuilt from every owned quanta's state (one all-gather): with `moved`, quanta go
  // to the ranks whose boxes hold them, the boxes cut anew when the ranks' loads drifted apart;
  // with `broke` (the topology changed), velocity Verlet's forces are evaluated afresh.
  void migrate(bool moved = true, bool broke = false);
  // The step's formation (set_form_rules), into whole_ and events_; returns the energy the new
  // bonds hold, which the rules added [J] (the same on every rank).
  double decide_forms();
  // This rank's charges for the bonds the step formed whose first end it owns, over the step.
  void charge_formed();
  // Whether the step's end edits bonds: plastic or break rules, or bonds that fail at their law's stretch.
  bool breaks() const { return !plastic_.empty() || !rules_.empty() || fails_; }
  // This rank's edits of its owned bonds (ledger_) at the step's end positions: the plastic rules'
  // flow and ductile breaks, the break rules' breaks (the draws in the whole world's order), then
  // the bonds past their law's failure stretch. Returns the energy they charged [J].
  double decide_breaks();
  // Breaks bond b of ledger_ by rule `rule` (the plastic rules, then the break rules, numbered in
  // that order; reason `why`), recorded in whole indices.
  void break_owned(std::size_t rule, std::size_t b, std::uint8_t why);
  // Every rank's rest lengths that the step's plastic flow changed into whole_ and the piece;
  // returns whether any bond flowed (the same on every rank).
  bool share_rests();
  // Every rank's breaks of the step into events_ (in a run on one rank's order) and whole_'s topology.
  void share_breaks();
  // The projection rules' heuristics on this rank's piece, its books of them from none.
  void add_projection_rules();
  // ContactRanks, for quanta contact as a projection rule.
  const Model& whole_model() const override { return whole_.model; }
  const Adjacency& whole_adjacency() const override { return whole_adj_; }
  std::span<const Index> whole_index() const override { return global_; }
  Index local_index(Index whole) const override { return local_of_[whole]; }
  std::vector<double> gather(std::span<const double> mine) override;
  // The rules with their selections in this piece's local indices.
  void localise_rules();
  // `rule` with its selection (by whole index) in this piece's local indices.
  template <class Rule>
  Rule localised(Rule rule) const;
  // coupled_implicit and the hybrid's sweeps: components_ (and for the sweeps whole_coloring_)
  // from whole_'s topology.
  void find_components();
  // RanksLink, for the hybrid's sweeps and rk4's stages: each piece's passes linked to the others'.
  const std::vector<std::uint8_t>& owned() const override { return owned_mask_; }
  const Coloring& coloring() const override { return coloring_; }
  void exchange(std::vector<Vec3>& y) override;
  void sum(std::span<double> sums) override;
  void restore_momentum(const Model& model, const std::vector<Vec3>& f_ext, double h,
                        std::vector<Vec3>& dv) override;
  void solve(const Model& model, const State& state, const Adjacency& adj, const ImplicitSystem& sys,
             double tolerance, std::vector<Vec3>& y, SolveStats& stats) override;
  // The owned quanta's [index, x, v, carried] rows (kRow doubles each).
  std::vector<double> owned_rows() const;
  // Whether an owned quanta of this rank's piece (which it must have) lies farther than margin_
  // outside the rank's box: it then moves to the rank whose box holds it (migrate).
  bool left_box() const;
  // The kind of carry-over the pieces hold.
  CarryKind carry_kind() const;

  World whole_;  // the model and topology (all ranks), the state as of the last migration
  IntegratorConfig config_;
  double h_;
  BlowupLimits limits_;
  bool verlet_;
  bool implicit_;  // coupled_implicit: the pieces' steps solve one system over the ranks
  bool restore_;   // restore_energy, done over the ranks (the pieces' configs have it off)
  bool newton_;    // energy_momentum, implicit_midpoint, bdf2: Newton's iterations linked over the ranks
  bool sweeps_;    // hybrid_implicit with sweeps or Jacobi iterations
  bool linked_;    // the sweeps and rk4: the pieces' passes (stages) are linked to each other
  int rank_, ranks_;
  Bisection cuts_;
  // Each quanta's owner: the rank whose box held it when the owners were last assigned (it stays
  // while it lies within margin_ of its owner's box, so that a body vibrating across a cut does
  // not move quanta between ranks every few steps).
  std::vector<int> owner_;
  double margin_ = 0;  // the longest bond's rest length [m]; 0 without bonds
  std::vector<Index> global_;            // local quanta → whole index
  std::vector<Index> owned_;             // local indices of the owned quanta
  std::vector<std::uint8_t> owned_mask_;  // 1 for each owned local quanta, 0 for ghosts
  std::unique_ptr<Simulation> sim_;      // null when this rank holds no quanta
  HaloPlan plan_;
  Halo halo_;
  // The ledger: a state of the piece's quanta with the owned bonds alone, holding the positions
  // and velocities before the step.
  State ledger_;
  Adjacency ledger_adj_;
  Projection moved_;
  std::vector<Vec3> gravity_;   // m g per local quanta
  double anchors_ = 0, damping_ = 0, loads_ = 0;  // this rank's share since the run started [J]
  // This rank's share of backward Euler's numerical damping since the run started (or since the
  // last restore_energy gave it back), and charge_ledger's last charge of it [J].
  double numerical_damping_ = 0, charged_numerical_damping_ = 0;
  // What this rank's heuristics took out since the run started (the bonds it broke, its
  // projection rules' edits, less on rank 0 what the formed bonds hold) [J], and its obstacles'
  // impulses on its owned quanta.
  double heuristics_loss_ = 0;
  std::vector<ObstacleImpulse> impulse_, start_impulse_;  // start: the whole run's when this one started
  std::vector<ProjectionRule> projection_rules_;
  // Each whole quanta's index in the piece (kNone: none). With quanta contact as a projection rule:
  // the whole world's adjacency, and how far an owned quanta's projection, before the rules
  // edited it, lay from where it was when the pieces were built (and which quanta) [m].
  std::vector<Index> local_of_;
  bool gathers_contacts_ = false;
  Adjacency whole_adj_;
  double projected_moved_ = 0;
  Index projected_worst_ = 0;
  // Penalty contacts or contacts solved in the step: whether the model has them, and the energy
  // they took out since the run started and their springs' energy now, over every rank [J].
  bool contacts_ = false;
  // coupled_implicit's obstacle contacts inside the solve (each owned quanta's, on its rank), and
  // whether they have friction.
  bool solved_contacts_ = false, rubs_ = false;
  double split_h_ = 0;  // while split_step takes its halves, the whole step's length [s]; else 0
  double contact_dissipated_ = 0, contact_stored_ = 0;
  PenaltyContact contact_after_;  // contact_stored_after's
  // Quanta–quanta contact: the pieces hold as ghosts the quanta within reach_ = 2 radius + 2 slack_
  // of their quanta (contact_halo); while no quanta has moved slack_ from where it was when they
  // were built (built_at_, per owned quanta), every pair that touches is in the piece of each of its ends.
  double reach_ = 0, slack_ = 0;  // [m]; 0 without quanta contact
  std::vector<Vec3> built_at_;
  bool fails_ = false;                  // some bond's law fails at its stretch (cohesive)
  std::vector<BreakRule> rules_;        // selections by whole index
  std::vector<BreakRule> local_rules_;  // selections by local index
  std::vector<PlasticRule> plastic_, local_plastic_;  // likewise
  PlasticFlow flow_;
  std::vector<double> flowed_;          // this rank's flowed bonds of the step: [whole bond, rest length]
  std::vector<Index> local_bond_of_;    // each whole bond's index in the piece (kNone: none)
  BreakCriteria criteria_;
  bool stress_limits_ = false;          // some break rule has a stress limit
  std::vector<Mat3> stress_;            // with those: each local quanta's virial stress at the step's end
  State stressed_;                      // with those and plastic rules: the piece's bonds the stress reads
  std::vector<Index> ledger_whole_;     // each ledger_ bond's whole index
  std::vector<Vec3> after_;             // the piece's positions after the step (the rules read them)
  std::vector<Vec3> after_v_;           // projection_gains: the projected end's velocities
  Projection still_;                    // no change: the rules test the state after the step
  StepContext break_ctx_;               // the step the rules test
  std::vector<double> broken_;          // this rank's breaks of the step: [rule, bond, i, j, reason, strain, tension]
  std::vector<BondEvent> events_;
  std::vector<FormRule> form_rules_;
  std::vector<BondLaw> form_laws_;  // each rule's bond law in whole_'s shapes
  FormationPass former_;
  EnergyLedger start_books_;          // the whole ledger when the run started (opened if it was not)
  // coupled_implicit and the hybrid's sweeps: the whole world's free components, found anew when
  // bonds break; the sweeps': the whole world's colouring, and this piece's share of both.
  FreeComponents components_;
  Coloring whole_coloring_, coloring_;
  SolveLayout layout_;
  std::unique_ptr<RanksSolve> ranks_solve_;  // the Newton integrators' linear solves (for layout_)
  Times times_;
  SolveStats solve_stats_;
  Energies energy_start_;  // the energies over every rank at the step's start
  // restore_energy: net_books() when the last step ended, and the whole world's components (of
  // topology version motion_version_).
  double net_books_ = 0;
  MotionComponents motion_;
  std::uint64_t motion_version_ = ~0ull;
  bool stop_agreed_ = false;
  // Adaptive steps: the controller's settings, the run's end and the next try's length [s]; the
  // try in progress (its length, the error estimate, whether it was rejected) and the books when
  // its step began.
  std::optional<AdaptiveConfig> adaptive_;
  double t_end_ = 0, proposal_ = 0, last_h_ = 0;
  struct AdaptiveTry {
    AdaptiveController control;
    AdaptiveController::Try at;
    double books0 = 0, error = 0;
    bool rejected = false;
  };
  std::optional<AdaptiveTry> try_;
  std::optional<Carry> carry0_;  // the piece's carry-over when the step began (undoable())
  EnergyGain gain_;
  std::uint64_t migrations_ = 0;
  std::uint64_t recuts_ = 0;
  std::uint64_t halo_rebuilds_ = 0;
  std::uint64_t retakes_ = 0;
  std::uint64_t halved_ = 0;
};

}  // namespace qbond::distributed
