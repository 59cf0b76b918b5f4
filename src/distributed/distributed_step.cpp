#include "distributed/distributed_step.hpp"

#include <algorithm>
#include <cassert>
#include <chrono>
#include <ctime>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "distributed/collectives.hpp"
#include "heuristics/breaking.hpp"
#include "heuristics/spatial_hash.hpp"
#include "integrators/advance.hpp"
#include "integrators/bond_forces.hpp"
#include "integrators/bond_partition.hpp"
#include "integrators/energy_guard.hpp"
#include "integrators/integrator_common.hpp"
#include "integrators/newton.hpp"
#include "ledger/step_work.hpp"
#include "qbond/analysis/analysis.hpp"
#include "qbond/analysis/stress.hpp"
#include "qbond/distributed/distributed.hpp"
#include "qbond/heuristics/contacts.hpp"
#include "qbond/integrators/carry.hpp"
#include "qbond/io/vtk.hpp"
#include "simulation/stages.hpp"

namespace qbond::distributed {

namespace {

// What a step carries to the next per quanta, kCarried numbers a quanta: velocity Verlet's
// forces, or an iterative solve's last Δv (SolverGuess), and the one before (SolverGuessPair), or
// BDF2's state a step back (Bdf2History: x and v), zeros where there are fewer. A row of
// owned_rows() is a quanta's whole index, x, v and these.
constexpr std::size_t kCarried = 6;
constexpr std::size_t kRow = 7 + kCarried;

// Quanta q's carried numbers in `c` into out (kCarried of them).
void carried_row(const Carry& c, std::size_t q, double* out) {
  std::fill_n(out, kCarried, 0.0);
  if (const auto* f = std::get_if<VerletForces>(&c)) {
    for (std::size_t k = 0; k < 3; ++k) out[k] = f->f[k * f->stride() + q];
  } else if (const auto* g = std::get_if<SolverGuess>(&c)) {
    std::copy_n(g->dv[q].data(), 3, out);
  } else if (const auto* p = std::get_if<SolverGuessPair>(&c)) {
    std::copy_n(p->dv[q].data(), 3, out);
    std::copy_n(p->dv_before[q].data(), 3, out + 3);
  } else if (const auto* b = std::get_if<Bdf2History>(&c)) {
    std::copy_n(b->x[q].data(), 3, out);
    std::copy_n(b->v[q].data(), 3, out + 3);
  }
}

CarryKind kind_of(const Carry& c) {
  using enum CarryKind::Kind;
  if (std::holds_alternative<VerletForces>(c)) return {.kind = forces};
  if (std::holds_alternative<SolverGuess>(c)) return {.kind = guess};
  if (const auto* p = std::get_if<SolverGuessPair>(&c)) return {.kind = guesses, .h = p->h, .h_before = p->h_before};
  if (const auto* b = std::get_if<Bdf2History>(&c)) return {.kind = history, .h = b->h, .t = b->t, .step = b->step};
  return {};
}

// The carry-over of `kind` for the quanta of a state from their carried numbers c (kCarried a
// quanta, in the state's order): velocity Verlet's forces with the state's own positions and
// velocities (what its step left, so that the next step takes them), or a solve's guesses.
Carry carry_from(const State& s, const std::vector<double>& c, const CarryKind& kind) {
  using enum CarryKind::Kind;
  const std::size_t n = s.x.size();
  auto vec = [&](std::size_t q, std::size_t at) { return Vec3(&c[kCarried * q + at]); };
  if (kind.kind == forces) {
    VerletForces f;
    f.resize(n);
    f.topology_version = s.topology_version();
    const std::size_t stride = f.stride();
    for (std::size_t q = 0; q < n; ++q) {
      for (std::size_t k = 0; k < 3; ++k) {
        f.f[k * stride + q] = c[kCarried * q + k];
        f.x[k * stride + q] = s.x[q][static_cast<Eigen::Index>(k)];
      }
      f.v[q] = s.v[q];
    }
    return f;
  }
  if (kind.kind == guess) {
    SolverGuess g;
    g.dv.resize(n);
    for (std::size_t q = 0; q < n; ++q) g.dv[q] = vec(q, 0);
    return g;
  }
  if (kind.kind == guesses) {
    SolverGuessPair p{.dv = {}, .dv_before = {}, .h = kind.h, .h_before = kind.h_before};
    p.dv.resize(n);
    p.dv_before.resize(n);
    for (std::size_t q = 0; q < n; ++q) {
      p.dv[q] = vec(q, 0);
      p.dv_before[q] = vec(q, 3);
    }
    return p;
  }
  if (kind.kind == history) {
    Bdf2History b{.x = std::vector<Vec3>(n), .v = std::vector<Vec3>(n), .t = kind.t, .h = kind.h, .step = kind.step};
    for (std::size_t q = 0; q < n; ++q) {
      b.x[q] = vec(q, 0);
      b.v[q] = vec(q, 3);
    }
    return b;
  }
  return std::monostate{};
}

// Writes the rows of owned_rows() of every rank into x, v and c (kCarried per quanta) by whole
// index; throws unless every quanta of n appears exactly once.
void unpack_rows(const std::vector<double>& rows, std::size_t n, std::vector<Vec3>& x, std::vector<Vec3>& v,
                 std::vector<double>& c);

// Load per rank beyond which a migration cuts the boxes anew: the most loaded rank holds this
// much more than the mean.
constexpr double kImbalance = 1.1;

// The run alone's energy guard (guard_energy.cpp, coupled.cpp): a step creating more than this
// fraction of its energy terms' magnitudes is taken again in halves, at most kMaxDepth deep.
constexpr double kGainTolerance = 1e-9;
constexpr int kMaxDepth = 10;

// What a step's contacts took out: their impulses' negative work less what their springs gained,
// as a run on one rank charges it (the explicit integrators' finish_contact, ContactSolve::finish) [J].
double contact_loss(const Projection::ContactEnergy& c) { return std::max(0.0, -c.work - (c.stored - c.stored_start)); }

}  // namespace

DistributedStep::DistributedStep(const World& whole, const IntegratorConfig& config, double h,
                                 const BlowupLimits& limits)
    : whole_(whole),
      config_(config),
      h_(h),
      limits_(limits),
      verlet_(config.type == IntegratorType::velocity_verlet),
      implicit_(config.type == IntegratorType::coupled_implicit),
      restore_(config.restore_energy),
      newton_(newton_integrator(config.type)),
      sweeps_(config.type == IntegratorType::hybrid_implicit && config.neighbours != NeighbourModel::frozen),
      linked_(sweeps_ || newton_ || config.type == IntegratorType::rk4),
      rank_(mpi_rank()),
      ranks_(mpi_ranks()),
      start_books_(whole.state.energy) {
  open_ledger(whole_.model, whole_.state, start_books_);  // as a run on one rank's Simulation does
  energy_start_ = energies(whole_.model, whole_.state);
  last_h_ = h;
  config_.restore_energy = false;  // restored here, over the ranks, not by each piece
  solved_contacts_ = implicit_ && whole_.model.solves_contact() &&
                    whole_.model.step_contact_method() == ContactMethod::implicit;
  rubs_ = solved_contacts_rub(whole_.model);
  contacts_ = PenaltyContact::used(whole_.model) || solved_contacts_;
  const Bonds& wb = whole_.state.bonds;
  for (std::size_t b = 0; b < wb.size() && !fails_; ++b) fails_ = wb.alive[b] && law_breaks(wb.law[b]);
  contact_stored_ = start_books_.contact_stored;
  if (const QuantaContactRule& rule = whole_.model.quanta_contact;
      rule.radius > 0 && rule.method == ContactMethod::penalty) {
    slack_ = rule.radius;
    reach_ = 2 * rule.radius + 2 * slack_;
  }
  for (std::size_t b = 0; b < wb.size(); ++b)
    if (wb.alive[b]) margin_ = std::max(margin_, wb.rest[b]);
  find_components();
  cuts_ = bisect(whole_.state.x, ranks_);
  owner_ = parts_of(cuts_, whole_.state.x);
  // What the whole world's step carries (a resumed run's), when it holds for this world and
  // integrator: velocity Verlet's forces, a solve's guesses.
  const Carry& c = whole_.state.carry;
  const std::size_t n = whole_.num_quanta();
  const auto* forces = std::get_if<VerletForces>(&c);
  const auto* guess = std::get_if<SolverGuess>(&c);
  const auto* guesses = std::get_if<SolverGuessPair>(&c);
  const auto* history = std::get_if<Bdf2History>(&c);
  const bool holds = verlet_ ? forces && forces->holds_for(n, whole_.state.topology_version())
                             : (guess && guess->fits(n)) || (guesses && guesses->fits(n)) ||
                                   (history && history->x.size() == n);
  std::vector<double> carried;
  if (holds) {
    carried.resize(kCarried * n);
    for (std::size_t q = 0; q < n; ++q) carried_row(c, q, &carried[kCarried * q]);
  }
  const CarryKind kind = holds ? kind_of(c) : CarryKind{};
  whole_.state.carry = std::monostate{};
  build(holds ? &carried : nullptr, kind);
  if (restore_) net_books_ = net_books();
}

DistributedStep::~DistributedStep() = default;

void DistributedStep::find_components() {
  if (!implicit_ && !sweeps_ && !newton_) return;
  Adjacency adj;
  build_adjacency(whole_.model, whole_.state, adj);
  free_components(whole_.model, adj, components_);
  if (sweeps_) color_free_quanta(whole_.model, adj, whole_coloring_);
}

void DistributedStep::exchange(std::vector<Vec3>& y) {
  halo_.exchange(
      plan_, 3, [&](Index q, double* out) { std::copy_n(y[q].data(), 3, out); },
      [&](Index q, const double* in) { std::copy_n(in, 3, y[q].data()); });
}

void DistributedStep::sum(std::span<double> sums) {
  const std::vector<double> all = all_gather(sums);
  std::fill(sums.begin(), sums.end(), 0.0);
  for (std::size_t r = 0; r + sums.size() <= all.size(); r += sums.size())
    for (std::size_t k = 0; k < sums.size(); ++k) sums[k] += all[r + k];
}

void DistributedStep::restore_momentum(const Model& model, const std::vector<Vec3>& f_ext, double h,
                                       std::vector<Vec3>& dv) {
  restore_momentum_over_ranks(layout_, model, f_ext, h, dv);
}

void DistributedStep::solve(const Model& model, const State& state, const Adjacency& adj, const ImplicitSystem& sys,
                            double tolerance, std::vector<Vec3>& y, SolveStats& stats) {
#ifdef QBOND_DISTRIBUTED_IMPLICIT
  if (!ranks_solve_) ranks_solve_ = make_ranks_solve(layout_, state, adj, config_);
  ranks_solve_->solve(model, state.bonds, adj, sys, tolerance, y, stats);
#else
  (void)model, (void)state, (void)adj, (void)sys, (void)tolerance, (void)y, (void)stats;
  throw std::logic_error("a solve over ranks needs PETSc: check_distributable refuses the integrators that take one");
#endif
}

ContactHalo DistributedStep::contact_halo() const {
  ContactHalo halo;
  if (solved_contacts_ && whole_.model.quanta_contact.radius > 0) {
    halo.everything = true;
    halo.layers = 1;
    return halo;
  }
  if (reach_ == 0) return halo;
  // Velocity Verlet with penalty contact moves a ghost by its own contacts before the owned
  // quanta's read it: a second layer. A projection rule reads the ghosts' projection, exchanged.
  const QuantaContactRule& penalty = whole_.model.quanta_contact;
  halo.layers = verlet_ && penalty.radius > 0 && penalty.method == ContactMethod::penalty ? 2 : 1;
  const std::vector<Vec3>& x = whole_.state.x;
  SpatialHash grid;
  grid.build(x, reach_);
  grid.pairs(x, [&](Index i, Index j) {
    if ((x[j] - x[i]).norm() < reach_) halo.near.emplace_back(i, j);
  });
  return halo;
}

void DistributedStep::build(const std::vector<double>* carried, const CarryKind& kind) {
  const ContactHalo halo = contact_halo();
  Piece piece = make_piece(whole_, owner_, rank_, halo);
  plan_ = halo_plan(whole_, owner_, rank_, piece, halo);
  global_ = std::move(piece.global);
  owned_ = std::move(piece.owned_quanta);
  owned_mask_ = std::move(piece.owned);
  local_of_.assign(whole_.num_quanta(), kNone);
  for (std::size_t l = 0; l < global_.size(); ++l) local_of_[global_[l]] = static_cast<Index>(l);
  contact_after_ = PenaltyContact{};
  built_at_.clear();
  if (reach_ > 0)
    for (Index q : owned_) built_at_.push_back(whole_.state.x[global_[q]]);
  World& w = piece.world;
  const std::size_t n = global_.size();
  // The ledger's state: the piece's owned bonds alone.
  ledger_ = State{};
  Bonds& lb = ledger_.edit_bonds();
  const Bonds& pb = w.state.bonds;
  ledger_whole_.clear();
  local_bond_of_.assign(whole_.state.bonds.size(), kNone);
  for (std::size_t b = 0; b < piece.whole_bond.size(); ++b) local_bond_of_[piece.whole_bond[b]] = static_cast<Index>(b);
  for (Index b : piece.owned_bonds) {
    append_bond(pb, b, pb.i[b], pb.j[b], lb);
    ledger_whole_.push_back(piece.whole_bond[b]);
  }
  lb.first_formed = lb.size();
  build_adjacency(w.model, ledger_, ledger_adj_);
  still_.resize(n);
  localise_rules();
  gravity_.resize(n);
  for (std::size_t q = 0; q < n; ++q) gravity_[q] = w.model.mass[q] * w.model.gravity;
  moved_.resize(n);
  // Every owned bond once over the ranks: the pieces hold the whole world's bonds. The implicit
  // solve needs every rank in every step, and a rank without quanta takes none.
  {
    const std::vector<double> mine{static_cast<double>(piece.owned_bonds.size()),
                                   static_cast<double>(owned_.size())};
    const std::vector<double> all = all_gather(mine);
    double total = 0, fewest = HUGE_VAL;
    for (std::size_t r = 0; r + 2 <= all.size(); r += 2) {
      total += all[r];
      fewest = std::min(fewest, all[r + 1]);
    }
    if (total != static_cast<double>(piece.whole_alive_bonds))
      throw std::logic_error("the ranks' pieces hold " + std::to_string(total) + " bonds of " +
                             std::to_string(piece.whole_alive_bonds));
    if ((implicit_ || linked_) && fewest == 0)
      throw std::invalid_argument("a run of " + std::to_string(whole_.num_quanta()) + " quanta over " +
                                  std::to_string(ranks_) + " ranks leaves a rank without quanta, which the " +
                                  (implicit_  ? "implicit solve"
                                   : sweeps_  ? "hybrid's sweeps"
                                   : newton_  ? "Newton iteration"
                                              : "rk4 step") +
                                  " over ranks cannot take; run it on fewer ranks");
  }
  // What the piece's step carries: the whole world's for its quanta, or velocity Verlet's forces
  // of this piece for its owned quanta (whose bonds it holds all of) and the owners' for its ghosts.
  std::vector<double> local(kCarried * n, 0.0);
  if (carried)
    for (std::size_t q = 0; q < n; ++q)
      std::copy_n(&(*carried)[kCarried * global_[q]], kCarried, &local[kCarried * q]);
  Carry carry;
  if (carried) {
    carry = carry_from(w.state, local, kind);
  } else if (verlet_) {
    carry = carry_from(w.state, fresh_forces(w), {.kind = CarryKind::Kind::forces});
  }
  sim_.reset();
  if (n == 0) return;
  sim_ = std::make_unique<Simulation>(std::move(w), config_, h_);
  sim_->limits() = limits_;
  sim_->set_track_energy(false);  // the ledger is charged here, over the owned bonds
  sim_->leave_failures_to_caller();  // decide_breaks, each bond by one rank
  add_projection_rules();
  if (sweeps_) {
    // The whole world's colour classes, restricted to this piece's quanta, in local order.
    coloring_ = {};
    coloring_.offset.push_back(0);
    for (std::size_t c = 0; c < whole_coloring_.num_colors(); ++c) {
      for (Index k = whole_coloring_.offset[c]; k < whole_coloring_.offset[c + 1]; ++k)
        if (const Index l = local_of_[whole_coloring_.quanta[k]]; l != kNone) coloring_.quanta.push_back(l);
      coloring_.offset.push_back(static_cast<Index>(coloring_.quanta.size()));
    }
  }
  if (sweeps_ || newton_) layout_ = solve_layout(whole_, owner_, rank_, ranks_, global_, owned_, components_);
  ranks_solve_.reset();  // made for this layout on the first solve
  if (linked_ || contacts_) {
    // The piece's step linked to the other ranks', its contacts' books those of the owned quanta
    // (added up over the ranks in agree()).
    std::unique_ptr<StepIntegrator> linked = make_step_integrator(config_);
    linked->link_to_ranks(*this);
    linked->count_contact_books_of(owned_mask_);
    replace_step_integrator(*sim_, std::move(linked));
  }
#ifdef QBOND_DISTRIBUTED_IMPLICIT
  if (implicit_)
    replace_step_integrator(
        *sim_, make_coupled_over_ranks(config_, solve_layout(whole_, owner_, rank_, ranks_, global_, owned_, components_),
                                       split_h_));
#endif
  sim_->world().state.carry = std::move(carry);  // after the integrators are replaced, which drop it
}

std::vector<double> DistributedStep::fresh_forces(const World& w) {
  const std::size_t n = global_.size();
  std::vector<double> local(kCarried * n, 0.0);
  if (n > 0) {
    Adjacency adj;
    build_adjacency(w.model, w.state, adj);
    BondPartition part;
    part.update(w.model, w.state.bonds, adj, config_.threads);
    ForceArrays work;
    const ForceRows rows =
        bond_force_rows(w.model, w.state, part, w.state.x.data(), w.state.v.data(), config_.threads, work);
    for (std::size_t q = 0; q < n; ++q)
      for (std::size_t k = 0; k < 3; ++k) local[kCarried * q + k] = rows.f[k][q];
  }
  halo_.exchange(
      plan_, 3, [&](Index q, double* out) { std::copy_n(&local[kCarried * q], 3, out); },
      [&](Index q, const double* in) { std::copy_n(in, 3, &local[kCarried * q]); });
  return local;
}

StepReport DistributedStep::piece_step() {
  if (whole_piece()) return sim_->step();
  if (projection_rules_.empty()) return sim_->end_step();
  Projection& p = sim_->projection();
  halo_.exchange(
      plan_, 6,
      [&](Index q, double* out) {
        std::copy_n(p.dx[q].data(), 3, out);
        std::copy_n(p.dv[q].data(), 3, out + 3);
      },
      [&](Index q, const double* in) {
        std::copy_n(in, 3, p.dx[q].data());
        std::copy_n(in + 3, 3, p.dv[q].data());
      });
  // Quanta contact finds its pairs at these ends: the piece holds them while none is slack_ away.
  projected_moved_ = 0;
  if (gathers_contacts_) {
    const State& s = sim_->world().state;
    for (std::size_t k = 0; k < built_at_.size(); ++k) {
      const Index q = owned_[k];
      const double d = (s.x[q] + p.dx[q] - built_at_[k]).norm();
      if (d > projected_moved_) projected_moved_ = d, projected_worst_ = global_[q];
    }
  }
  if (implicit_ && projection_gains()) {
    // The run alone's guard takes this projection again in halves before the rules edit it.
    StepReport r;
    r.status = StepReport::Status::blowup;
    r.message = "at step " + std::to_string(whole_.state.step + 1) +
                " the implicit step would create energy before the obstacles and contact edit it; the run alone "
                "takes it again in halves, which over ranks is not distributed yet: take smaller steps, or run it "
                "on one rank; the world keeps the state before this step";
    return r;
  }
  return sim_->end_step();
}

bool DistributedStep::projection_gains() {
  const World& w = sim_->world();
  const Projection& p = sim_->projection();
  const std::size_t n = global_.size();
  after_.resize(n);
  after_v_.resize(n);
  for (std::size_t q = 0; q < n; ++q) {
    after_[q] = w.state.x[q] + p.dx[q];
    after_v_[q] = w.state.v[q] + p.dv[q];
  }
  // This rank's kinetic energy, gravity's potential, bonds' energy and work, over its owned
  // quanta and bonds, at the projected end (as charge_ledger and agree sum them after the step).
  const StepWork work = step_work(w.model, ledger_, ledger_adj_, p, {after_, after_v_}, gravity_, h_,
                                  sim_->integrator().ledger_hints(), config_.threads);
  double mine[7] = {0, 0, work.bonds_after, work.anchors + owned_loads_work(w.model, p.dx), 0, 0, 0};
  if (p.contact.charged) mine[4] = p.contact.work, mine[5] = p.contact.stored, mine[6] = p.contact.stored_start;
  for (Index q : owned_) {
    if (w.model.is_kinematic(q)) continue;
    const double m = w.model.mass[q];
    mine[0] += 0.5 * m * after_v_[q].squaredNorm();
    mine[1] -= m * w.model.gravity.dot(after_[q]);
  }
  const std::vector<double> all = all_gather(mine);
  Verdict v;
  for (std::size_t r = 0; r + 7 <= all.size(); r += 7) {
    v.after.kinetic += all[r];
    v.after.gravity += all[r + 1];
    v.after.bonds += all[r + 2];
    v.work += all[r + 3];
    v.contact.work += all[r + 4];
    v.contact.stored += all[r + 5];
    v.contact.stored_start += all[r + 6];
  }
  return gains(v, Guard::projection);
}

double DistributedStep::owned_loads_work(const Model& m, const std::vector<Vec3>& dx) const {
  double work = 0;
  for (const Load& load : m.loads) {
    if (load.quanta.empty()) continue;
    const Vec3 share = load.share();
    for (Index q : load.quanta)
      if (owned_mask_[q] && !m.is_kinematic(q)) work += share.dot(dx[q]);
  }
  return work;
}

bool DistributedStep::edited() const {
  if (!sim_ || projection_rules_.empty()) return false;
  const State& s = sim_->world().state;
  const auto* c = std::get_if<VerletForces>(&s.carry);
  if (!c) return false;
  const std::size_t stride = c->stride();
  return std::any_of(owned_.begin(), owned_.end(), [&](Index q) {
    for (std::size_t k = 0; k < 3; ++k)
      if (c->x[k * stride + q] != s.x[q][static_cast<Eigen::Index>(k)]) return true;
    return c->v[q] != s.v[q];
  });
}

bool DistributedStep::left_box() const {
  const State& s = sim_->world().state;
  Vec3 lo, hi;
  cuts_.box(rank_, lo, hi);
  return std::any_of(owned_.begin(), owned_.end(), [&](Index q) {
    for (int k = 0; k < 3; ++k)
      if (s.x[q][k] < lo[k] - margin_ || s.x[q][k] >= hi[k] + margin_) return true;
    return false;
  });
}

std::string DistributedStep::layout(std::span<const Vec3> x) const {
  Strays strays;
  for (std::size_t q = 0; q < x.size(); ++q)
    if (const int p = cuts_.part_of(x[q]); p != owner_[q]) strays.emplace_back(static_cast<Index>(q), owner_[q]);
  return bisection_json(cuts_, strays);
}

CarryKind DistributedStep::carry_kind() const { return sim_ ? kind_of(sim_->world().state.carry) : CarryKind{}; }

SolveLayout solve_layout(const World& whole, std::span<const int> owner, int rank, int ranks,
                         std::span<const Index> global, std::span<const Index> owned,
                         const FreeComponents& components) {
  // The whole system's block rows: each rank's owned free quanta in whole-world order, rank after
  // rank (the same numbering on every rank, from the owners alone).
  const std::size_t n = whole.num_quanta();
  std::vector<std::int64_t> next(static_cast<std::size_t>(ranks) + 1, 0);
  for (std::size_t q = 0; q < n; ++q)
    if (!whole.model.is_kinematic(static_cast<Index>(q))) ++next[static_cast<std::size_t>(owner[q]) + 1];
  for (std::size_t r = 1; r < next.size(); ++r) next[r] += next[r - 1];
  SolveLayout layout;
  layout.first_row = next[static_cast<std::size_t>(rank)];
  layout.rows = next.back();
  std::vector<std::int64_t> rows(n, -1);
  for (std::size_t q = 0; q < n; ++q)
    if (!whole.model.is_kinematic(static_cast<Index>(q))) rows[q] = next[static_cast<std::size_t>(owner[q])]++;
  std::vector<Index> local(n, kNone);
  layout.row.resize(global.size());
  for (std::size_t l = 0; l < global.size(); ++l) {
    local[global[l]] = static_cast<Index>(l);
    layout.row[l] = rows[global[l]];
  }
  for (Index l : owned)
    if (layout.row[l] >= 0) layout.owned_free.push_back(l);
  const FreeComponents& c = components;
  layout.component_offset.push_back(0);
  for (std::size_t k = 0; k + 1 < c.offset.size(); ++k) {
    for (Index m = c.offset[k]; m < c.offset[k + 1]; ++m)
      if (owner[c.quanta[m]] == rank) layout.component_owned.push_back(local[c.quanta[m]]);
    layout.component_offset.push_back(static_cast<Index>(layout.component_owned.size()));
  }
  layout.component_mass = c.mass;
  for (std::size_t k = 0; k + 1 < c.offset.size(); ++k)
    if (const Index q = c.quanta[c.offset[k]]; c.offset[k + 1] - c.offset[k] == 1 && owner[q] == rank)
      layout.lone.push_back(local[q]);
  return layout;
}

void restore_momentum_over_ranks(const SolveLayout& layout, const Model& model, const std::vector<Vec3>& f_ext,
                                 double h, std::vector<Vec3>& dv, const std::vector<std::uint8_t>& skip) {
  // Per component: the external impulse wanted, the momentum change got, and the members skipped.
  constexpr std::size_t kSums = 7;
  const std::size_t nc = layout.component_mass.size();
  std::vector<double> sums(kSums * nc, 0.0);
  for (std::size_t c = 0; c < nc; ++c)
    for (Index k = layout.component_offset[c]; k < layout.component_offset[c + 1]; ++k) {
      const Index i = layout.component_owned[k];
      const Vec3 wanted = h * external_force(model, f_ext, i), got = model.mass[i] * dv[i];
      for (int j = 0; j < 3; ++j) {
        sums[kSums * c + static_cast<std::size_t>(j)] += wanted[j];
        sums[kSums * c + 3 + static_cast<std::size_t>(j)] += got[j];
      }
      if (!skip.empty() && skip[i]) sums[kSums * c + 6] = 1;
    }
  const std::vector<double> all = all_gather(sums);
  for (std::size_t c = 0; c < nc; ++c) {
    Vec3 wanted = Vec3::Zero(), got = Vec3::Zero();
    bool held = false;
    for (std::size_t r = 0; r + kSums * nc <= all.size(); r += kSums * nc) {
      const double* a = &all[r + kSums * c];
      wanted += Vec3(a[0], a[1], a[2]);
      got += Vec3(a[3], a[4], a[5]);
      held = held || a[6] != 0;
    }
    if (held) continue;
    const Vec3 shift = (wanted - got) / layout.component_mass[c];
    for (Index k = layout.component_offset[c]; k < layout.component_offset[c + 1]; ++k)
      dv[layout.component_owned[k]] += shift;
  }
}

namespace {
// CPU time of this process [s].
double cpu_seconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }
// Wall time on a steady clock [s].
double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

StepReport DistributedStep::step(bool stop) {
  const double wall0 = wall_seconds(), cpu0 = cpu_seconds();
  StepReport r = adaptive_ ? adaptive_step(stop) : step_timed(stop, cpu0);
  times_.wall += wall_seconds() - wall0;
  ++times_.steps;
  return r;
}

StepReport DistributedStep::step_timed(bool stop, double cpu0, bool retaken) {
  StepReport report;  // this rank's piece's
  bool left = false;  // an owned quanta left this rank's box
  const double t0 = whole_.state.time;
  if (sim_) {
    State& s = sim_->world().state;
    ledger_.x = s.x;
    ledger_.v = s.v;
    if (undoable()) carry0_ = s.carry;
    if (!whole_piece()) sim_->begin_step();
  }
  if (try_ && rejects_error()) return {};  // before anything changed: nothing to undo
  if (sim_) {
    report = piece_step();
    solve_stats_ = sim_->integrator().stats();  // before a rebuild makes a new integrator
    left = report.status == StepReport::Status::ok && left_box();
  } else if (gathers_contacts_) {
    gather({});  // the pieces' contact rules gather the quanta in contact every step
  }
  const bool unconverged = newton_unconverged();
  times_.stepping += cpu_seconds() - cpu0;
  // A piece that refused its step sends its state before it: the step is then undone everywhere.
  exchange_ghosts();
  const double cpu1 = cpu_seconds();
  // The break rules, on the state after the step (the run alone's projected state), before the
  // ledger: a bond broken in the step is not charged for it, as on one rank.
  const Rng rng0 = whole_.state.rng;
  // (A piece that refused its step tests it too: the draws are collective; the step is undone.)
  const double fractured = breaks() ? decide_breaks() : 0.0;
  const StepWork work = charge_ledger(h_);
  times_.bookkeeping += cpu_seconds() - cpu1;
  Verdict v = agree(report, left, stop, work, contacts_ ? contact_stored_after() : 0.0, fractured);
  auto undo = [&] {
    if (sim_) {
      roll_back(work);
      restore_carry();
    }
    heuristics_loss_ -= fractured;
    whole_.state.rng = rng0;
    events_.clear();
    rebuild_after_roll_back();
  };
  if (v.report.status == StepReport::Status::ok && v.moved > slack_ && reach_ > 0) {
    // A contact of the step may have been missed: taken again from pieces built at its start,
    // unless it was (a quanta then moved that far in this one step).
    if (!retaken) {
      undo();
      ++retakes_;
      return step_timed(stop, cpu_seconds(), true);
    }
    std::ostringstream msg;
    msg.precision(6);
    msg << "at step " << whole_.state.step + 1 << " (t = " << whole_.state.time + h_ << " s) quanta "
        << whole_.model.quanta_id[v.report.worst] << " moved " << v.moved
        << " m in one step, more than its contact radius: over ranks the contacts cannot follow it; take "
           "smaller steps, or run it on one rank; the world keeps the state before this step";
    v.report.status = StepReport::Status::blowup;
    v.report.message = msg.str();
  }
  if (v.report.status != StepReport::Status::ok) {
    undo();
    return v.report;
  }
  // With projection rules the run alone guards the projection before their edits alone. A Newton
  // step that did not converge is taken in halves, as the run alone's integrator takes it.
  if ((implicit_ && projection_rules_.empty() && gains(v, Guard::step)) || unconverged) {
    undo();
    ++halved_;
    return split_step(stop, cpu_seconds());
  }
  // limits.stop_on_energy_gain: judged before the step's breaks are shared, while it can still be
  // undone (check_distributable refuses it beside form rules and restore_energy, whose energy
  // comes after them).
  if (limits_.stop_on_energy_gain)
    if (StepReport r = record_gain(v, 0.0); r.status != StepReport::Status::ok) {
      undo();
      return kept_before(std::move(r));
    }
  // Adaptive steps: the books as the step leaves them, this rank's projection rules' loss and the
  // contacts' charges below included.
  if (try_ && !try_->at.at_min) {
    const double pending = sim_ && !projection_rules_.empty() ? sim_->world().state.energy.dissipated_heuristics : 0.0;
    const double books = contacts_ ? net_books(pending, contact_dissipated_ + contact_loss(v.contact), v.contact.stored)
                                   : net_books(pending, contact_dissipated_, contact_stored_);
    if (drifted(energy_start_.total(), v.after, books)) {
      undo();
      return {};
    }
  }
  const double e_start = std::exchange(energy_start_, v.after).total();
  stop_agreed_ = v.stop;
  if (contacts_) {
    // As a run on one rank charges them (the explicit integrators' finish_contact).
    contact_dissipated_ += contact_loss(v.contact);
    contact_stored_ = v.contact.stored;
  }
  if (sim_ && !projection_rules_.empty()) {
    // This rank's projection rules' books of the step, kept here: a piece built anew starts from none.
    State& s = sim_->world().state;
    heuristics_loss_ += std::exchange(s.energy.dissipated_heuristics, 0.0);
    for (std::size_t k = 0; k < impulse_.size(); ++k) {
      impulse_[k].total += s.obstacle_impulse[k].total;
      impulse_[k].normal += s.obstacle_impulse[k].normal;
      s.obstacle_impulse[k] = {};
    }
  }
  // The flow's rest lengths into every piece holding the bonds, before their forces are read.
  const bool flowed = !plastic_.empty() && share_rests();
  if (breaks()) share_breaks();  // at the step's start time, as the run alone breaks them
  const double formed = form_rules_.empty() ? 0.0 : decide_forms();
  energy_start_.bonds += formed;
  const double restored = restore_ ? restore_energy(e_start) : 0.0;
  if (v.edited || (verlet_ && (flowed || restored != 0))) {
    State& s = sim_ ? sim_->world().state : whole_.state;
    const std::vector<double> forces = fresh_forces(sim_ ? sim_->world() : whole_);
    if (sim_) s.carry = carry_from(s, forces, {.kind = CarryKind::Kind::forces});
  }
  if (!limits_.stop_on_energy_gain) record_gain(v, formed + restored);
  whole_.state.time = t0 + h_;  // as every piece's step sets it
  whole_.state.step += 1;
  // Pieces built anew before a quanta can move past their contact halos.
  const bool refresh = reach_ > 0 && v.moved > 0.5 * slack_;
  if (refresh) ++halo_rebuilds_;
  if (v.migrate || !events_.empty() || refresh) migrate(v.migrate, !events_.empty());
  return {};
}

void DistributedStep::set_adaptive(const AdaptiveConfig& config, double t_end, double proposal, double last) {
  adaptive_ = config;
  t_end_ = t_end;
  proposal_ = proposal;
  last_h_ = last;
}

StepReport DistributedStep::adaptive_step(bool stop) {
  // As adaptive_step alone: the books and energy when the step began give its drift.
  try_.emplace(AdaptiveTry{.control = AdaptiveController(*adaptive_, proposal_), .at = {}, .books0 = net_books()});
  for (;;) {
    AdaptiveTry& t = *try_;
    t.at = t.control.next_try(whole_.state.time, t_end_);
    t.rejected = false;
    h_ = t.at.step;
    if (sim_) sim_->set_timestep(h_);
    StepReport r = step_timed(stop, cpu_seconds());
    if (t.rejected) continue;
    if (r.status != StepReport::Status::ok && !t.at.at_min) {  // undone by step_timed
      t.control.reject_undone(t.at);
      continue;
    }
    if (r.status == StepReport::Status::ok && t.at.last) {
      // t + (t_end − t) may miss t_end by an ulp
      whole_.state.time = t_end_;
      if (sim_) sim_->world().state.time = t_end_;
    }
    last_h_ = t.at.step;
    proposal_ = t.control.next_proposal(t.at, t.error);
    try_.reset();
    return r;
  }
}

bool DistributedStep::rejects_error() {
  const double mine[1] = {sim_ ? step_error(sim_->world().model, sim_->world().state, sim_->projection(), h_, owned_)
                               : 0.0};
  double e = 0;
  for (double x : all_gather(mine)) e = std::max(e, x);
  try_->error = e;
  return try_->rejected = try_->control.rejects_error(try_->at, e);
}

bool DistributedStep::drifted(double e_before, const Energies& after, double books) {
  AdaptiveTry& t = *try_;
  // The budget's `numerical` is the books less E − E(0): its change over the step.
  const double change = (books - t.books0) - (after.total() - e_before);
  const double scale = std::max(std::abs(start_books_.initial_total), std::abs(after.kinetic) + std::abs(after.bonds));
  if (!t.control.drifts(t.at, change, scale)) return false;
  t.control.reject_undone(t.at);
  return t.rejected = true;
}

void DistributedStep::roll_back(const StepWork& work) {
  State& s = sim_->world().state;
  s.x = ledger_.x;
  s.v = ledger_.v;
  s.time = whole_.state.time;
  s.step = whole_.state.step;
  anchors_ -= work.anchors;
  damping_ -= work.damping;
  loads_ -= work.loads;
  numerical_damping_ -= charged_numerical_damping_;
}

void DistributedStep::restore_carry() {
  if (carry0_) sim_->world().state.carry = std::move(*carry0_);
  carry0_.reset();
}

void DistributedStep::rebuild_after_roll_back() {
  // The pieces are rebuilt from the state before the step with what it carried when the step may
  // be undone (restore_carry); else velocity Verlet's forces are evaluated afresh by their owners
  // and a solve starts without a guess.
  std::vector<double> c;
  unpack_rows(all_gather(owned_rows()), whole_.num_quanta(), whole_.state.x, whole_.state.v, c);
  const CarryKind kind = undoable() ? carry_kind() : CarryKind{};
  build(kind.kind != CarryKind::Kind::none ? &c : nullptr, kind);
}

double DistributedStep::contact_stored_after() {
  if (!sim_) return 0;
  if (solved_contacts_) return sim_->projection().contact.stored;  // the owned quanta's, at the step's end
  const State& s = sim_->world().state;
  contact_after_.evaluate(sim_->world().model, sim_->adjacency(), h_, PointsView::of(s.x.data(), s.v.data()),
                          owned_mask_);
  return contact_after_.stored();
}

bool DistributedStep::newton_unconverged() {
  // bdf2 is never split (its step reads the state one whole step back); the iterations' decisions
  // are taken over every rank, so each piece's verdict is the same: the flag over the ranks only
  // keeps a rank without a piece in step.
  if (!newton_ || config_.type == IntegratorType::bdf2) return false;
  int flags[1] = {sim_ && sim_->integrator().stats().unconverged > 0 ? 1 : 0};
  max_over_ranks(flags);
  return flags[0] != 0;
}

bool DistributedStep::gains(const Verdict& v, Guard guard) const {
  // Contacts solved with friction may show a gain up to their energies, as alone.
  Projection::ContactEnergy c = v.contact;
  c.dissipated = contact_loss(c);
  c.charged = solved_contacts_;
  const double allowance = friction_allowance(c, rubs_);
  const bool credit = guard == Guard::step && !breaks() && form_rules_.empty();  // no heuristics
  const Energies& e0 = energy_start_;
  const double lost = credit ? v.damping : 0.0;
  // The solved contacts' impulses' work is theirs: their springs and dampers are the ledger's.
  const double gain = v.after.total() + v.released - e0.total() - v.work - c.work + lost;
  const double scale = e0.kinetic + e0.bonds + v.after.kinetic + v.after.bonds + std::abs(v.released) +
                       std::abs(v.after.gravity - e0.gravity) + std::abs(v.work) + std::abs(c.work) + std::abs(lost);
  return gain > kGainTolerance * scale + allowance + (credit ? limits_.energy_floor : 0.0);
}

double DistributedStep::net_books(double pending, double contact_dissipated, double contact_stored) {
  const double mine[3] = {anchors_ + loads_, damping_, heuristics_loss_ + pending};
  const std::vector<double> all = all_gather(mine);
  double net = -contact_dissipated - contact_stored;
  for (std::size_t r = 0; r + 3 <= all.size(); r += 3) net += all[r] - all[r + 1] - all[r + 2];
  return net;
}

double DistributedStep::restore_energy(double e_start) {
  // The run alone's stage::restore_energy: E(end) should be E(start) plus the step's change of the
  // books; what is missing the integrator removed (or made).
  const double net = net_books();
  const double delta = e_start + (net - net_books_) - energy_start_.total();
  net_books_ = net;
  numerical_damping_ = 0;  // given back with the rest of what the integrator removed, as alone
  if (motion_version_ != whole_.state.topology_version()) {
    Adjacency adj;
    build_adjacency(whole_.model, whole_.state, adj);
    motion_ = motion_components(whole_.model, adj);
    motion_version_ = whole_.state.topology_version();
  }
  std::vector<Index> quanta, component;
  if (sim_)
    for (Index q : owned_)
      if (const Index c = motion_.of[global_[q]]; c != kNone) {
        quanta.push_back(q);
        component.push_back(c);
      }
  World& w = sim_ ? sim_->world() : whole_;  // a rank without quanta only adds its zeros
  const InternalScaling r = scale_internal_velocities(w.model, quanta, component, motion_.anchored, w.state, delta,
                                                      [this](std::span<double> sums) { sum(sums); });
  if (r.lambda == 1) return 0;
  exchange_ghosts();
  const double added = (r.lambda * r.lambda - 1) * r.internal_kinetic;
  energy_start_.kinetic += added;
  return added;
}

StepReport DistributedStep::kept_before(StepReport r) {
  r.message += "; the world keeps the state before this step";  // as the run alone's roll_back says
  return r;
}

StepReport DistributedStep::record_gain(const Verdict& v, double bonds) {
  return stage::record_gain(v.gain + bonds, v.available, whole_.state.step + 1, whole_.state.time + h_, limits_,
                            gain_);
}

StepReport DistributedStep::split_step(bool stop, double cpu0) {
  const double t0 = whole_.state.time;
  // The pieces' state and this rank's books at the step's start, for a blow-up in a half.
  std::vector<Vec3> x0, v0;
  if (sim_) {
    x0 = sim_->world().state.x;
    v0 = sim_->world().state.v;
    if (undoable()) carry0_ = sim_->world().state.carry;
  }
  const double anchors0 = anchors_, damping0 = damping_, loads0 = loads_, numerical_damping0 = numerical_damping_;
  const double contact_dissipated0 = contact_dissipated_, contact_stored0 = contact_stored_;
  const Energies e0 = energy_start_;
  solve_stats_ = {};
  Verdict last;
  split_h_ = h_;  // the contacts' springs keep the whole step's stiffness
  const bool ok = half(t0, t0 + 0.5 * h_, 1, stop, last) && half(t0 + 0.5 * h_, t0 + h_, 1, stop, last);
  split_h_ = 0;
  times_.stepping += cpu_seconds() - cpu0;
  auto undo = [&] {
    if (sim_) {
      State& s = sim_->world().state;
      s.x = std::move(x0);
      s.v = std::move(v0);
      s.time = t0;
      s.step = whole_.state.step;
      restore_carry();
    }
    anchors_ = anchors0;
    damping_ = damping0;
    loads_ = loads0;
    numerical_damping_ = numerical_damping0;
    contact_dissipated_ = contact_dissipated0;
    contact_stored_ = contact_stored0;
    energy_start_ = e0;
    rebuild_after_roll_back();
  };
  if (!ok) {
    undo();
    return last.report;
  }
  // The breaks follow the whole step, as the run alone's heuristics follow its integrator; the
  // energy they take leaves the next step's start.
  double bonds = 0;  // the change of the bonds' energy after the last half: broken, formed
  const Rng rng0 = whole_.state.rng;
  const double mine[1] = {breaks() ? decide_breaks() : 0.0};
  if (breaks())
    for (double fractured : all_gather(mine)) bonds -= fractured;
  auto undo_breaks = [&] {
    heuristics_loss_ -= mine[0];
    whole_.state.rng = rng0;
    events_.clear();
    undo();
  };
  if (limits_.stop_on_energy_gain)
    if (StepReport r = record_gain(last, bonds); r.status != StepReport::Status::ok) {
      undo_breaks();
      return kept_before(std::move(r));
    }
  if (try_ && !try_->at.at_min) {
    Energies after = last.after;
    after.bonds += bonds;
    if (drifted(e0.total(), after, net_books())) {
      undo_breaks();
      return {};
    }
  }
  if (breaks() && !plastic_.empty()) share_rests();
  int flags[1] = {0};  // a quanta left its rank's box
  if (sim_) {
    State& s = sim_->world().state;
    s.time = t0 + h_;
    s.step = whole_.state.step + 1;
    flags[0] = left_box();
  }
  max_over_ranks(flags);
  stop_agreed_ = last.stop;
  if (breaks()) share_breaks();
  if (!form_rules_.empty()) bonds += decide_forms();
  energy_start_.bonds += bonds;
  const double restored = restore_ ? restore_energy(e0.total()) : 0.0;
  if (!limits_.stop_on_energy_gain) record_gain(last, bonds + restored);
  whole_.state.time = t0 + h_;
  whole_.state.step += 1;
  if (flags[0] || !events_.empty()) migrate(flags[0] != 0, !events_.empty());
  return {};
}

bool DistributedStep::half(double t_a, double t_b, int depth, bool stop, Verdict& last) {
  const double H = t_b - t_a;
  StepReport report;
  if (sim_) {
    State& s = sim_->world().state;
    ledger_.x = s.x;
    ledger_.v = s.v;
    s.time = t_a;
    sim_->set_timestep(H);
    if (!whole_piece()) sim_->begin_step();
    report = piece_step();
    sim_->set_timestep(h_);
    const SolveStats& taken = sim_->integrator().stats();
    solve_stats_.iterations += taken.iterations;
    solve_stats_.residual = std::max(solve_stats_.residual, taken.residual);
  }
  const bool unconverged = newton_unconverged();
  exchange_ghosts();
  const StepWork work = charge_ledger(H);
  last = agree(report, false, stop, work, solved_contacts_ ? contact_stored_after() : 0.0, 0.0);
  const bool ok = last.report.status == StepReport::Status::ok;
  // A Newton half is split again while its iteration does not converge, the coupled step's while
  // it creates energy, each to its integrator's depth, as alone.
  const bool again = newton_ ? unconverged && depth < kNewtonSplitDepth : depth < kMaxDepth && gains(last, Guard::half);
  if (ok && !again) {
    if (unconverged) ++solve_stats_.unconverged;  // the smallest half, taken anyway
    energy_start_ = last.after;
    if (solved_contacts_) {  // each half's contacts charged as the run alone's substeps are
      contact_dissipated_ += contact_loss(last.contact);
      contact_stored_ = last.contact.stored;
    }
    return true;
  }
  if (sim_) {
    roll_back(work);
    sim_->world().state.time = t_a;
  }
  if (!ok) return false;
  const double tm = t_a + 0.5 * H;
  return half(t_a, tm, depth + 1, stop, last) && half(tm, t_b, depth + 1, stop, last);
}

DistributedStep::Verdict DistributedStep::agree(const StepReport& report, bool left, bool stop,
                                                const StepWork& work, double contact_after,
                                                double released) const {
  // Each rank's flags (its step refused, a quanta out of its box, a stop asked for) and its sums
  // over its owned quanta and bonds (kinetic energy, gravity's potential, the impulse allowance,
  // the bonds' energy, the anchors' work, its fastest free quanta's speed and index, and the loads'
  // work; with penalty contacts, the farthest an owned quanta has moved since the pieces were
  // built and its index, and the contacts' books of the step; the step's work, dampers' loss and
  // broken bonds' energy), then every rank's, added in rank order: the same on every rank.
  constexpr std::size_t kFields = 20;
  const bool refused = report.status != StepReport::Status::ok;
  double mine[kFields] = {refused ? 1.0 : 0.0, left ? 1.0 : 0.0, stop ? 1.0 : 0.0, 0, 0, 0, work.bonds_after,
                          anchors_, -1, 0, loads_, 0, 0, 0, 0, 0, work.loads + work.anchors, work.damping,
                          released, !refused && verlet_ && edited() ? 1.0 : 0.0};
  if (refused) mine[9] = static_cast<double>(global_[report.worst]);
  if (sim_ && !refused) {
    const World& w = sim_->world();
    if (gathers_contacts_) mine[11] = projected_moved_, mine[12] = static_cast<double>(projected_worst_);
    for (std::size_t k = 0; k < built_at_.size(); ++k) {
      const double d = (w.state.x[owned_[k]] - built_at_[k]).norm();
      if (d > mine[11]) {
        mine[11] = d;
        mine[12] = static_cast<double>(global_[owned_[k]]);
      }
    }
    if (const Projection::ContactEnergy& c = sim_->projection().contact; c.charged) {
      mine[13] = c.work;
      mine[15] = c.stored_start;
    }
    mine[14] = contact_after;
    const double t = whole_.state.time + h_ - start_books_.initial_time;
    for (Index q : owned_) {
      if (w.model.is_kinematic(q)) continue;
      const double m = w.model.mass[q];
      mine[3] += 0.5 * m * w.state.v[q].squaredNorm();
      mine[4] -= m * w.model.gravity.dot(w.state.x[q]);
      mine[5] += 0.5 * w.model.inv_mass[q] * (t * (m * w.model.gravity)).squaredNorm();
      const double speed = w.state.v[q].norm();
      if (speed > mine[8]) {
        mine[8] = speed;
        mine[9] = static_cast<double>(global_[q]);
      }
    }
  }
  const std::vector<double> all = all_gather(mine);
  Verdict v;
  int first_refused = -1;
  double sum[5] = {0, 0, 0, 0, 0}, loads = 0, speed = -1, who = 0;
  for (std::size_t r = 0; r + kFields <= all.size(); r += kFields) {
    const double* a = &all[r];
    if (a[0] != 0 && first_refused < 0) first_refused = static_cast<int>(r / kFields);
    v.migrate = v.migrate || a[1] != 0;
    v.stop = v.stop || a[2] != 0;
    for (std::size_t k = 0; k < 5; ++k) sum[k] += a[3 + k];
    loads += a[10];
    if (a[11] > v.moved) {
      v.moved = a[11];
      v.report.worst = static_cast<Index>(a[12]);  // named if the step is refused for it
    }
    v.contact.work += a[13];
    v.contact.stored += a[14];
    v.contact.stored_start += a[15];
    v.work += a[16];
    v.damping += a[17];
    v.released += a[18];
    v.edited = v.edited || a[19] != 0;
    if (a[8] > speed) {
      speed = a[8];
      who = a[9];
    }
  }
  v.after = {.kinetic = sum[0], .bonds = sum[3], .gravity = sum[1]};
  if (first_refused >= 0) {
    // The step's own check refused it on some piece: that piece's report, the first by rank.
    v.report.status = StepReport::Status::blowup;
    v.report.message = report.message;
    broadcast(v.report.message, first_refused);
    v.report.worst = static_cast<Index>(all[kFields * static_cast<std::size_t>(first_refused) + 9]);
    return v;
  }
  // The energy runaway check of a run on one rank (Simulation::check_energy).
  const EnergyLedger& l = start_books_;
  const double work_anchors = l.work_anchors + sum[4];
  const double available = (l.initial_total - l.initial_gravity) + std::abs(sum[1] - l.initial_gravity) +
                           std::abs(l.work_loads + loads) + std::abs(work_anchors) + sum[2];
  const double held = sum[0] + sum[3];
  v.available = available;
  v.gain = v.after.total() - l.initial_total - (l.work_loads + loads) - work_anchors;
  if (held <= limits_.energy_growth * available + limits_.energy_floor) return v;
  const auto q = static_cast<Index>(who);
  std::ostringstream msg;
  msg.precision(6);
  msg << "blow-up at step " << whole_.state.step + 1 << " (t = " << whole_.state.time + h_
      << " s): energy runaway, kinetic + bond energy " << held << " J exceeds " << limits_.energy_growth << " x the "
      << available << " J the system could have gained; fastest quanta " << whole_.model.quanta_id[q] << " at "
      << speed << " m/s; the world keeps the state before this step";
  v.report.status = StepReport::Status::blowup;
  v.report.message = msg.str();
  v.report.worst = q;
  return v;
}

void DistributedStep::exchange_ghosts() {
  if (!sim_) return;
  State& s = sim_->world().state;
  VerletForces* c = verlet_ ? std::get_if<VerletForces>(&s.carry) : nullptr;
  const std::size_t stride = c ? c->stride() : 0;
  halo_.exchange(
      plan_, c ? 9 : 6,
      [&](Index q, double* out) {
        for (int k = 0; k < 3; ++k) {
          out[k] = s.x[q][k];
          out[3 + k] = s.v[q][k];
          if (c) out[6 + k] = c->f[k * stride + q];
        }
      },
      [&](Index q, const double* in) {
        for (int k = 0; k < 3; ++k) {
          s.x[q][k] = in[k];
          s.v[q][k] = in[3 + k];
          if (!c) continue;
          c->f[k * stride + q] = in[6 + k];
          c->x[k * stride + q] = in[k];
        }
        if (c) c->v[q] = s.v[q];
      });
}

StepWork DistributedStep::charge_ledger(double H) {
  if (!sim_) return {};
  const World& w = sim_->world();
  const std::size_t n = global_.size();
  for (std::size_t q = 0; q < n; ++q) {
    moved_.dx[q] = w.state.x[q] - ledger_.x[q];
    moved_.dv[q] = w.state.v[q] - ledger_.v[q];
  }
  StepWork work = step_work(w.model, ledger_, ledger_adj_, moved_, {w.state.x, w.state.v}, gravity_, H,
                                  sim_->integrator().ledger_hints(), config_.threads);
  anchors_ += work.anchors;
  damping_ += work.damping;
  work.loads += owned_loads_work(w.model, moved_.dx);
  loads_ += work.loads;
  // Backward Euler's numerical damping: the owned bonds' share and the owned quanta's (the
  // piece's projection holds those of its owned quanta only).
  charged_numerical_damping_ = numerical_damping(work, sim_->projection());
  numerical_damping_ += charged_numerical_damping_;
  return work;
}

std::vector<double> DistributedStep::owned_rows() const {
  std::vector<double> rows;
  if (!sim_) return rows;
  const State& s = sim_->world().state;
  rows.resize(kRow * owned_.size());
  double* row = rows.data();
  for (Index q : owned_) {
    row[0] = static_cast<double>(global_[q]);
    for (int k = 0; k < 3; ++k) {
      row[1 + k] = s.x[q][k];
      row[4 + k] = s.v[q][k];
    }
    carried_row(s.carry, q, row + 7);
    row += kRow;
  }
  return rows;
}

namespace {
void unpack_rows(const std::vector<double>& rows, std::size_t n, std::vector<Vec3>& x, std::vector<Vec3>& v,
                 std::vector<double>& c) {
  std::vector<std::uint8_t> seen(n, 0);
  std::size_t count = 0;
  c.assign(kCarried * n, 0.0);
  for (std::size_t r = 0; r + kRow <= rows.size(); r += kRow) {
    const auto q = static_cast<std::size_t>(rows[r]);
    if (q >= n || seen[q]) throw std::logic_error("quanta " + std::to_string(q) + " is held by two ranks");
    seen[q] = 1;
    ++count;
    x[q] = Vec3(rows[r + 1], rows[r + 2], rows[r + 3]);
    v[q] = Vec3(rows[r + 4], rows[r + 5], rows[r + 6]);
    std::copy_n(&rows[r + 7], kCarried, &c[kCarried * q]);
  }
  if (count != n)
    throw std::logic_error("the ranks hold " + std::to_string(count) + " quanta of " + std::to_string(n));
}
}  // namespace

void DistributedStep::migrate(bool moved, bool broke) {
  std::vector<double> c;
  unpack_rows(all_gather(owned_rows()), whole_.num_quanta(), whole_.state.x, whole_.state.v, c);
  if (broke) find_components();  // a break may have split a free component
  // After a break velocity Verlet's carried forces were the old topology's: evaluated afresh, as
  // on one rank; a solve's guesses hold on.
  const CarryKind kind = carry_kind();
  const bool keep = kind.kind != CarryKind::Kind::none && !(verlet_ && broke);
  if (!moved) {
    build(keep ? &c : nullptr, kind);
    return;
  }
  ++migrations_;
  owner_ = parts_of(cuts_, whole_.state.x);
  std::vector<std::size_t> load(static_cast<std::size_t>(ranks_), 0);
  for (int o : owner_) ++load[static_cast<std::size_t>(o)];
  const double mean = static_cast<double>(whole_.num_quanta()) / ranks_;
  if (static_cast<double>(*std::max_element(load.begin(), load.end())) > kImbalance * mean) {
    cuts_ = bisect(whole_.state.x, ranks_);
    owner_ = parts_of(cuts_, whole_.state.x);
    ++recuts_;
  }
  build(keep ? &c : nullptr, kind);
}

void DistributedStep::take_cuts(Bisection cuts, const Strays& strays) {
  cuts_ = std::move(cuts);
  owner_ = parts_of(cuts_, whole_.state.x);
  for (const auto& [q, p] : strays) {
    assert(q < owner_.size());  // RanksRun checks the checkpoint's
    owner_[q] = p;
  }
  migrate(false);
}

void DistributedStep::write_piece(const std::filesystem::path& file) const {
  if (!sim_) {
    write_vtp_piece(file, Model{}, State{}, {}, {});
    return;
  }
  const World& w = sim_->world();
  std::vector<std::uint8_t> owned(global_.size(), 0);
  for (Index q : owned_) owned[q] = 1;
  const Bonds& b = w.state.bonds;
  std::vector<std::uint8_t> shown(b.size());
  for (std::size_t k = 0; k < b.size(); ++k) shown[k] = owned[b.i[k]];  // the ledger's rule: the first end's rank
  write_vtp_piece(file, w.model, w.state, owned, shown);
}

void DistributedStep::set_projection_rules(std::vector<ProjectionRule> rules) {
  projection_rules_ = std::move(rules);
  std::size_t records = 0;
  for (const ProjectionRule& rule : projection_rules_) {
    if (const auto* o = std::get_if<Obstacle>(&rule)) {
      records = std::max(records, static_cast<std::size_t>(o->record + 1));
    } else if (std::holds_alternative<QuantaContactRule>(rule)) {
      // The pieces' ghosts: every quanta an owned one can touch while none has moved slack_.
      gathers_contacts_ = true;
      slack_ = std::max(slack_, std::get<QuantaContactRule>(rule).radius);
      reach_ = 4 * slack_;
    }
  }
  start_impulse_ = whole_.state.obstacle_impulse;
  start_impulse_.resize(std::max(records, start_impulse_.size()));
  impulse_.assign(start_impulse_.size(), ObstacleImpulse{});
  if (gathers_contacts_) {
    migrate(false);  // the pieces built anew, with their contact halos
  } else {
    add_projection_rules();
  }
}

void DistributedStep::add_projection_rules() {
  if (!sim_ || projection_rules_.empty()) return;
  State& s = sim_->world().state;
  s.energy.dissipated_heuristics = 0;  // this rank's share, added to heuristics_loss_ after each step
  s.obstacle_impulse.assign(impulse_.size(), ObstacleImpulse{});
  if (gathers_contacts_) build_adjacency(whole_.model, whole_.state, whole_adj_);
  for (const ProjectionRule& rule : projection_rules_) {
    if (const auto* o = std::get_if<Obstacle>(&rule)) sim_->add_heuristic(make_heuristic(*o));
    else if (const auto* z = std::get_if<DampingZone>(&rule)) sim_->add_heuristic(make_heuristic(localised(*z)));
    else sim_->add_heuristic(make_heuristic(std::get<QuantaContactRule>(rule), static_cast<ContactRanks&>(*this)));
  }
  sim_->count_edits_of(owned_mask_);
}

std::vector<double> DistributedStep::gather(std::span<const double> mine) { return all_gather(mine); }

void DistributedStep::set_break_rules(std::vector<BreakRule> rules) {
  rules_ = std::move(rules);
  stress_limits_ = std::any_of(rules_.begin(), rules_.end(), [](const BreakRule& r) { return r.reads_stress(); });
  localise_rules();
}

void DistributedStep::set_plastic_rules(std::vector<PlasticRule> rules) {
  plastic_ = std::move(rules);
  localise_rules();
}

template <class Rule>
Rule DistributedStep::localised(Rule rule) const {
  if (rule.quanta.empty()) return rule;
  std::vector<std::uint8_t> mask(global_.size());
  for (std::size_t q = 0; q < global_.size(); ++q) mask[q] = rule.quanta[global_[q]];
  rule.quanta = std::move(mask);
  return rule;
}

void DistributedStep::localise_rules() {
  local_rules_.clear();
  for (const BreakRule& r : rules_) local_rules_.push_back(localised(r));
  local_plastic_.clear();
  for (const PlasticRule& r : plastic_) local_plastic_.push_back(localised(r));
}

void DistributedStep::break_owned(std::size_t rule, std::size_t b, std::uint8_t why) {
  const Model& m = sim_->world().model;
  std::vector<BondEvent> one;
  break_now(m, ledger_, break_ctx_, one, b, stretch(m, ledger_, still_, b), static_cast<BondEvent::Reason>(why));
  const BondEvent& e = one.front();
  broken_.insert(broken_.end(), {static_cast<double>(rule), static_cast<double>(ledger_whole_[b]),
                                 static_cast<double>(global_[e.i]), static_cast<double>(global_[e.j]),
                                 static_cast<double>(why), e.strain, e.tension});
}

double DistributedStep::decide_breaks() {
  broken_.clear();
  flowed_.clear();
  break_ctx_ = {.h = h_, .t = whole_.state.time, .step = whole_.state.step};
  // The rules read ledger_ (the owned bonds) with the positions after the step, exchanged for
  // the ghosts: the state a run on one rank projects, to the bit.
  if (sim_) {
    after_ = sim_->world().state.x;
    ledger_.x.swap(after_);
    ledger_.time = whole_.state.time;
    ledger_.energy.dissipated_heuristics = 0;
  }
  for (std::size_t k = 0; k < plastic_.size() && sim_; ++k) {
    // Each owned bond flows as the run alone's rule flows it; its ductile breaks follow, in bond order.
    const std::vector<std::uint8_t>& edit =
        flow_.flow(local_plastic_[k], sim_->world().model, ledger_, still_, config_.threads);
    for (std::size_t b = 0; b < edit.size(); ++b)
      if (edit[b] != PlasticFlow::kKept)
        flowed_.insert(flowed_.end(), {static_cast<double>(ledger_whole_[b]), ledger_.bonds.rest[b]});
    for (std::size_t b = 0; b < edit.size(); ++b)
      if (edit[b] == PlasticFlow::kDuctile) break_owned(k, b, static_cast<std::uint8_t>(BondEvent::Reason::ductility));
  }
  const std::size_t first = plastic_.size();  // the break rules' numbers
  if (stress_limits_) {
    // Each end's virial stress at the step's end: an owned quanta's from its piece, which holds
    // all its bonds (summed in the run alone's order), a ghost's from its owner. After plastic
    // rules, with every rank's flowed rest lengths and ductile breaks of the step, as the run
    // alone's break rules read them: on a copy of the piece's bonds, so that an undone step
    // leaves the pieces as they were.
    std::vector<double> edits;  // [whole bond, new rest length, or −1: broken]
    if (!plastic_.empty()) {
      edits = flowed_;
      for (std::size_t r = 0; r + 7 <= broken_.size(); r += 7) edits.insert(edits.end(), {broken_[r + 1], -1.0});
      edits = all_gather(edits);
    }
    if (sim_) {
      const World& w = sim_->world();
      if (!edits.empty()) {
        stressed_.edit_bonds() = w.state.bonds;
        for (std::size_t r = 0; r + 2 <= edits.size(); r += 2) {
          const Index l = local_bond_of_[static_cast<std::size_t>(edits[r])];
          if (l == kNone) continue;
          if (edits[r + 1] < 0)
            stressed_.break_bond(l);
          else
            stressed_.edit_bonds().rest[l] = edits[r + 1];
        }
      }
      virial_stress(w.model, edits.empty() ? w.state : stressed_, w.state.x, w.state.v, stress_);
      halo_.exchange(
          plan_, 9, [&](Index q, double* out) { std::copy_n(stress_[q].data(), 9, out); },
          [&](Index q, const double* in) { std::copy_n(in, 9, stress_[q].data()); });
    }
  }
  for (std::size_t k = 0; k < rules_.size(); ++k) {
    const BreakRule& rule = local_rules_[k];
    const bool draws = rule.probability < 1;
    std::vector<double> over;  // [whole bond, rank, ledger bond, reason] of the owned bonds over a threshold
    if (sim_) {
      const std::vector<std::uint8_t>& why =
          criteria_.evaluate(rule, sim_->world().model, ledger_, still_, config_.threads, stress_);
      for (std::size_t b = 0; b < why.size(); ++b) {
        if (why[b] == BreakCriteria::kNone) continue;
        if (!draws) {
          break_owned(first + k, b, why[b]);
          continue;
        }
        over.insert(over.end(), {static_cast<double>(ledger_whole_[b]), static_cast<double>(rank_),
                                 static_cast<double>(b), static_cast<double>(why[b])});
      }
    }
    if (!draws) continue;
    // One draw per bond over a threshold, in the whole world's bond order: the run alone's draws.
    const std::vector<double> all = all_gather(over);
    std::vector<std::size_t> rows(all.size() / 4);
    for (std::size_t r = 0; r < rows.size(); ++r) rows[r] = 4 * r;
    std::sort(rows.begin(), rows.end(), [&](std::size_t a, std::size_t b) { return all[a] < all[b]; });
    for (std::size_t r : rows) {
      if (!(whole_.state.rng.uniform() < rule.probability)) continue;
      if (static_cast<int>(all[r + 1]) == rank_)
        break_owned(first + k, static_cast<std::size_t>(all[r + 2]), static_cast<std::uint8_t>(all[r + 3]));
    }
  }
  // Bonds past their law's failure stretch, after the rules, in bond order (break_failed_bonds).
  if (sim_ && fails_) {
    const Model& m = sim_->world().model;
    const Bonds& lb = ledger_.bonds;
    for (std::size_t b = 0; b < lb.size(); ++b)
      if (lb.alive[b] && law_breaks(lb.law[b]) && past_failure(m, ledger_, b, stretch(m, ledger_, still_, b)))
        break_owned(first + rules_.size(), b, static_cast<std::uint8_t>(BondEvent::Reason::failure));
  }
  if (!sim_) return 0.0;
  ledger_.x.swap(after_);
  if (!broken_.empty()) build_adjacency(sim_->world().model, ledger_, ledger_adj_);
  heuristics_loss_ += ledger_.energy.dissipated_heuristics;
  return ledger_.energy.dissipated_heuristics;
}

void DistributedStep::share_breaks() {
  constexpr std::size_t kWidth = 7;
  const std::vector<double> all = all_gather(broken_);
  std::vector<std::size_t> rows(all.size() / kWidth);
  for (std::size_t r = 0; r < rows.size(); ++r) rows[r] = kWidth * r;
  // A run on one rank records its rules' breaks rule by rule, each in bond order.
  std::sort(rows.begin(), rows.end(), [&](std::size_t a, std::size_t b) {
    return std::pair(all[a], all[a + 1]) < std::pair(all[b], all[b + 1]);
  });
  events_.clear();
  for (std::size_t r : rows) {
    BondEvent e;
    e.kind = BondEvent::Kind::broken;
    e.reason = static_cast<BondEvent::Reason>(static_cast<int>(all[r + 4]));
    e.step = whole_.state.step;
    e.time = whole_.state.time + h_;
    e.bond = static_cast<Index>(all[r + 1]);
    e.i = static_cast<Index>(all[r + 2]);
    e.j = static_cast<Index>(all[r + 3]);
    e.strain = all[r + 5];
    e.tension = all[r + 6];
    events_.push_back(e);
  }
  apply_events(whole_);
}

bool DistributedStep::share_rests() {
  const std::vector<double> all = all_gather(flowed_);
  if (all.empty()) return false;
  Bonds& wb = whole_.state.bonds;  // rest lengths only: no topology change
  for (std::size_t r = 0; r + 2 <= all.size(); r += 2) {
    const auto b = static_cast<std::size_t>(all[r]);
    wb.rest[b] = all[r + 1];
    if (sim_)
      if (const Index l = local_bond_of_[b]; l != kNone) sim_->world().state.bonds.rest[l] = all[r + 1];
  }
  if (sim_) drop_after_bond_edit(sim_->world().state.carry);  // as the run alone's heuristics stage does
  return true;
}

void DistributedStep::set_form_rules(std::vector<FormRule> rules) {
  form_rules_ = std::move(rules);
  form_laws_.clear();
  double capture = 0;
  for (const FormRule& rule : form_rules_) {
    form_laws_.push_back(bond_law(whole_.model, rule.bond));
    capture = std::max(capture, rule.capture_radius);
  }
  // The pieces' ghosts: every quanta within the capture radius of an owned one while none has
  // moved slack_ (the pairs are found at the step's end, which agree() measures).
  slack_ = std::max(slack_, capture);
  reach_ = 4 * slack_;
  migrate(false);
}

double DistributedStep::decide_forms() {
  // This rank's owned quanta within a capture radius of any quanta of its piece, at the step's
  // end (exchanged for the ghosts): rows [whole index, x].
  constexpr std::size_t kWidth = 4;
  std::vector<double> mine;
  if (sim_) {
    const std::vector<Vec3>& x = sim_->world().state.x;
    std::vector<std::uint8_t> near(x.size(), 0);
    SpatialHash grid;
    grid.build(x, slack_);
    grid.pairs(x, [&](Index i, Index j) { near[i] = near[j] = 1; });
    for (Index q : owned_)
      if (near[q]) mine.insert(mine.end(), {static_cast<double>(global_[q]), x[q].x(), x[q].y(), x[q].z()});
  }
  // Every rank forms the whole world's bonds among them in whole_, as the run alone's rules do.
  const std::vector<double> all = all_gather(mine);
  if (!breaks()) events_.clear();  // else the step's breaks, which the new bonds follow
  std::vector<std::size_t> rows(all.size() / kWidth);
  for (std::size_t r = 0; r < rows.size(); ++r) rows[r] = kWidth * r;
  std::sort(rows.begin(), rows.end(), [&](std::size_t a, std::size_t b) { return all[a] < all[b]; });
  std::vector<Index> ids;
  std::vector<Vec3> pos;
  for (std::size_t r : rows) {
    ids.push_back(static_cast<Index>(all[r]));
    pos.emplace_back(all[r + 1], all[r + 2], all[r + 3]);
  }
  State& s = whole_.state;
  const double before = s.energy.dissipated_heuristics;
  const StepContext ctx{.h = h_, .t = s.time, .step = s.step};
  Adjacency adj;
  for (std::size_t k = 0; k < form_rules_.size(); ++k) {
    if (k == 0 || adj.version != s.topology_version()) build_adjacency(whole_.model, s, adj);
    former_.run(form_rules_[k], form_laws_[k], whole_.model, s, adj, pos, ids, ctx, events_);
  }
  // The energy the new bonds hold, which the rules added: charged once, by rank 0.
  const double added = before - s.energy.dissipated_heuristics;
  s.energy.dissipated_heuristics = before;
  if (rank_ == 0) heuristics_loss_ -= added;
  charge_formed();
  return added;
}

void DistributedStep::charge_formed() {
  if (!sim_) return;
  // The run alone charges the step's ledger after its heuristics, over the bonds they leave: a
  // bond formed in the step is charged its dampers' and anchors' work over it. Here by the rank
  // that owns its first end, which holds its other (within the capture radius) in its piece.
  State formed;
  Bonds& fb = formed.edit_bonds();
  for (const BondEvent& e : events_)
    if (e.kind == BondEvent::Kind::formed && owner_[e.i] == rank_)
      append_bond(whole_.state.bonds, e.bond, local_of_[e.i], local_of_[e.j], fb);
  if (fb.size() == 0) return;
  fb.first_formed = 0;
  formed.x = ledger_.x;
  formed.v = ledger_.v;
  const World& w = sim_->world();
  Adjacency adj;
  build_adjacency(w.model, formed, adj);
  const StepWork work = step_work(w.model, formed, adj, moved_, {w.state.x, w.state.v}, gravity_, h_,
                                  sim_->integrator().ledger_hints(), config_.threads);
  anchors_ += work.anchors;
  damping_ += work.damping;
  numerical_damping_ += work.bonds_loss;
}

void DistributedStep::apply_events(World& w) const {
  for (const BondEvent& e : events_) {
    if (e.kind == BondEvent::Kind::formed) {
      if (&w == &whole_) continue;  // formed there
      const Bonds& b = whole_.state.bonds;
      const BondLaw law{.law = b.law[e.bond], .damping_model = b.damping_model[e.bond], .strength = b.strength[e.bond],
                        .damping = b.damping[e.bond], .shape = b.shape[e.bond]};
      w.state.form_bond(e.i, e.j, law, b.rest0[e.bond], e.bond);
      continue;
    }
    if (!w.state.bonds.alive[e.bond]) throw std::logic_error("bond " + std::to_string(e.bond) + " broke twice");
    w.state.break_bond(e.bond);
  }
}

void DistributedStep::gather(World& into) {
  const std::vector<double> rows = gather_to_root(owned_rows());
  // Each rank's books: anchors, dampers, heuristics, loads, numerical damping, then per obstacle
  // its impulse.
  const std::size_t fields = 5 + 4 * impulse_.size();
  std::vector<double> mine{anchors_, damping_, heuristics_loss_, loads_, numerical_damping_};
  for (const ObstacleImpulse& J : impulse_) mine.insert(mine.end(), {J.total.x(), J.total.y(), J.total.z(), J.normal});
  const std::vector<double> books = gather_to_root(mine);
  if (rank_ != 0) return;
  State& s = into.state;
  std::vector<double> c;
  unpack_rows(rows, into.num_quanta(), s.x, s.v, c);
  s.time = whole_.state.time;
  s.step = whole_.state.step;
  // The carried forces (after a blow-up, evaluated afresh at the state before it), or the solve's
  // guesses (after a blow-up, none).
  s.carry = carry_from(s, c, verlet_ ? CarryKind{.kind = CarryKind::Kind::forces} : carry_kind());
  double anchors = 0, damping = 0, fracture = 0, loads = 0, numerical = 0;
  s.obstacle_impulse = start_impulse_;
  for (std::size_t r = 0; r + fields <= books.size(); r += fields) {
    anchors += books[r];
    damping += books[r + 1];
    fracture += books[r + 2];
    loads += books[r + 3];
    numerical += books[r + 4];
    for (std::size_t k = 0; k < impulse_.size(); ++k) {
      const double* J = &books[r + 5 + 4 * k];
      s.obstacle_impulse[k].total += Vec3(J[0], J[1], J[2]);
      s.obstacle_impulse[k].normal += J[3];
    }
  }
  s.energy.work_anchors = start_books_.work_anchors + anchors;
  s.energy.work_loads = start_books_.work_loads + loads;
  s.energy.dissipated_damping = start_books_.dissipated_damping + damping;
  s.energy.dissipated_heuristics = start_books_.dissipated_heuristics + fracture;
  s.energy.dissipated_contact = start_books_.dissipated_contact + contact_dissipated_;
  s.energy.numerical_damping = start_books_.numerical_damping + numerical;
  s.energy.contact_stored = contact_stored_;
  s.rng = whole_.state.rng;  // the break rules' draws
  if (!plastic_.empty()) s.bonds.rest = whole_.state.bonds.rest;  // the plastic flow's
}

}  // namespace qbond::distributed
