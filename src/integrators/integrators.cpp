#include <algorithm>
#include <array>
#include <cstdlib>
#include <cassert>
#include <functional>
#include <initializer_list>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>

#include "integrators/integrator_common.hpp"
#include "integrators/prescribed.hpp"
#include "core/parallel.hpp"

namespace qbond {

IntegratorConfig default_integrator() {
  IntegratorConfig c;  // the struct's defaults are the shipped defaults; see docs/integrators.md
  return c;
}

int max_threads() {
  const unsigned hardware = std::thread::hardware_concurrency();
  return static_cast<int>(std::max(64u, 4 * std::min(hardware, 1u << 20)));
}

int checked_thread_count(int threads) {
  const int limit = max_threads();
  const std::string bound = max_threads_text();
  if (threads < 0) throw std::invalid_argument("threads: must be >= 0, got " + std::to_string(threads));
  if (threads > limit)
    throw std::invalid_argument("threads: must be <= " + bound + ", got " + std::to_string(threads));
  if (threads > 0) return threads;
  const int t = thread_count(0);
  if (t > limit) {
    const char* env = std::getenv("OMP_NUM_THREADS");
    throw std::invalid_argument("threads: OpenMP's default is " + std::to_string(t) + " threads" +
                                (env ? std::string(" (OMP_NUM_THREADS=") + env + ")" : std::string()) +
                                ", more than " + bound + "; set OMP_NUM_THREADS lower or give the threads");
  }
  return t;
}

std::string max_threads_text() {
  return std::to_string(max_threads()) + " (4 x this machine's " + std::to_string(std::thread::hardware_concurrency()) +
         " hardware threads, at least 64)";
}

namespace {

using O = IntegratorOption;

constexpr NamedValue<NeighbourModel> kNeighbourModels[] = {
    {NeighbourModel::frozen, "frozen", "neighbours held at their start positions and at rest (the paper)"},
    {NeighbourModel::sweep, "sweep", "block Gauss-Seidel on the coupled system, in graph-colour order"},
    {NeighbourModel::jacobi, "jacobi", "block Jacobi on the coupled system"},
};
constexpr NamedValue<CoupledSolver> kSolvers[] = {
    {CoupledSolver::dense, "dense", "dense Gaussian elimination (the paper's cubic-cost method)"},
    {CoupledSolver::ldlt, "ldlt", "sparse LDLT"},
    {CoupledSolver::cg, "cg", "matrix-free conjugate gradient, block-Jacobi preconditioned"},
    {CoupledSolver::sweep, "sweep", "block Gauss-Seidel sweeps in colour order"},
};
constexpr NamedValue<Preconditioner> kPreconditioners[] = {
    {Preconditioner::block_jacobi, "block_jacobi", "A's 3x3 diagonal blocks inverted (matrix-free)"},
    {Preconditioner::multigrid, "multigrid", "smoothed aggregation multigrid V-cycle, kept across steps"},
    {Preconditioner::automatic, "automatic", "block_jacobi, then multigrid once block Jacobi needs many iterations"},
};
constexpr NamedValue<WarmStart> kWarmStarts[] = {
    {WarmStart::zero, "zero", "dv = 0"},
    {WarmStart::external, "external", "dv = h f_ext / m"},
    {WarmStart::previous, "previous", "the previous step's dv"},
    {WarmStart::automatic, "auto", "extrapolated for coupled_implicit with cg, zero otherwise"},
    {WarmStart::extrapolated, "extrapolated", "2 dv(-1) - dv(-2) from the last two steps"},
};

template <class E>
bool contains(std::span<const E> list, E e) {
  return std::find(list.begin(), list.end(), e) != list.end();
}

template <class E>
std::string names(std::span<const E> list) {
  std::string out;
  for (E e : list) out += (out.empty() ? "" : ", ") + std::string(to_string(e));
  return out;
}

template <class Row>
std::string_view key_of(std::span<const Row> rows, decltype(Row{}.value) e) {
  for (const Row& r : rows)
    if (r.value == e) return r.key;
  return "?";
}

template <class Row>
auto parse_key(std::span<const Row> rows, std::string_view s, const char* what) {
  std::string all;
  for (const Row& r : rows) {
    if (r.key == s) return r.value;
    all += (all.empty() ? "" : ", ") + std::string(r.key);
  }
  throw std::invalid_argument(std::string("unknown ") + what + " '" + std::string(s) + "' (expected one of: " + all +
                              ")");
}

}  // namespace

std::span<const IntegratorInfo> integrator_table() {
  // The rows the integrators' files define, copied on first use (after every file's constants).
  static const IntegratorInfo table[] = {
#define QBOND_INTEGRATOR_ROW(name) name##_integrator,
      QBOND_INTEGRATORS(QBOND_INTEGRATOR_ROW)
#undef QBOND_INTEGRATOR_ROW
  };
  return table;
}
std::span<const IntegratorOptionInfo> integrator_options() { return kIntegratorOptions; }
std::span<const NamedValue<NeighbourModel>> neighbour_models() { return kNeighbourModels; }
std::span<const NamedValue<CoupledSolver>> coupled_solvers() { return kSolvers; }
std::span<const NamedValue<WarmStart>> warm_starts() { return kWarmStarts; }
std::span<const NamedValue<Preconditioner>> preconditioners() { return kPreconditioners; }

bool IntegratorInfo::reads(IntegratorOption o) const {
  for (const IntegratorOptionInfo& row : kIntegratorOptions)
    if (row.option == o) return (row.read_by >> static_cast<int>(type)) & 1;
  return false;
}

const IntegratorInfo& integrator_info(IntegratorType t) {
  for (const IntegratorInfo& i : integrator_table())
    if (i.type == t) return i;
  throw std::invalid_argument("unknown integrator type " + std::to_string(static_cast<int>(t)));
}

std::unique_ptr<Integrator> make_integrator(const IntegratorConfig& config) {
  return make_step_integrator(config);
}

std::unique_ptr<StepIntegrator> make_step_integrator(const IntegratorConfig& config) {
  IntegratorConfig c = config;
  const IntegratorInfo& info = integrator_info(c.type);
  c.warm_start = resolved_warm_start(c);
  if (c.iterations < 1) throw std::invalid_argument("integrator.iterations: must be >= 1");
  if (c.threads < 0) throw std::invalid_argument("integrator.threads: must be >= 0 (0: all cores)");
  if (c.max_iterations < 0) throw std::invalid_argument("integrator.max_iterations: must be >= 0");
  if (!(c.tolerance >= 0)) throw std::invalid_argument("integrator.tolerance: must be >= 0");
  if (!(c.chebyshev_rho >= 0 && c.chebyshev_rho < 1))
    throw std::invalid_argument("integrator.chebyshev_rho: must be in [0, 1)");
  if (info.reads(O::solver) && !contains(info.solvers, c.solver))
    throw std::invalid_argument("integrator.solver: " + std::string(info.key) + " takes " + names(info.solvers) +
                                ", not '" + std::string(to_string(c.solver)) + "'");
  if (info.reads(O::warm_start) && !contains(info.warm_starts, c.warm_start))
    throw std::invalid_argument("integrator.warm_start: " + std::string(info.key) + " takes " +
                                names(info.warm_starts) + ", not '" + std::string(to_string(c.warm_start)) + "'");
  if (info.reads(O::newton_iterations) && c.newton_iterations < 1)
    throw std::invalid_argument("integrator.newton_iterations: must be >= 1");
  return info.make(c);
}

std::string_view to_string(IntegratorType t) {
  for (const IntegratorInfo& i : integrator_table())
    if (i.type == t) return i.key;
  return "?";
}
std::string_view to_string(NeighbourModel m) { return key_of<NamedValue<NeighbourModel>>(kNeighbourModels, m); }
std::string_view to_string(CoupledSolver s) { return key_of<NamedValue<CoupledSolver>>(kSolvers, s); }
std::string_view to_string(WarmStart w) { return key_of<NamedValue<WarmStart>>(kWarmStarts, w); }
std::string_view to_string(Preconditioner p) { return key_of<NamedValue<Preconditioner>>(kPreconditioners, p); }
std::string_view to_string(IntegratorOption o) {
  for (const IntegratorOptionInfo& i : kIntegratorOptions)
    if (i.option == o) return i.key;
  return "?";
}

IntegratorType parse_integrator_type(std::string_view s) {
  std::string all;
  for (const IntegratorInfo& i : integrator_table()) {
    if (i.key == s) return i.type;
    all += (all.empty() ? "" : ", ") + std::string(i.key);
  }
  throw std::invalid_argument("unknown integrator '" + std::string(s) + "' (expected one of: " + all + ")");
}
NeighbourModel parse_neighbour_model(std::string_view s) {
  return parse_key<NamedValue<NeighbourModel>>(kNeighbourModels, s, "neighbour model");
}
CoupledSolver parse_coupled_solver(std::string_view s) {
  return parse_key<NamedValue<CoupledSolver>>(kSolvers, s, "solver");
}
WarmStart parse_warm_start(std::string_view s) {
  return parse_key<NamedValue<WarmStart>>(kWarmStarts, s, "warm start");
}
Preconditioner parse_preconditioner(std::string_view s) {
  return parse_key<NamedValue<Preconditioner>>(kPreconditioners, s, "preconditioner");
}

void project_kinematic(const Model& model, const State& state, const StepContext& ctx,
                       Projection& out) {
  for (const Motion& m : model.motions) {
    for (std::size_t k = 0; k < m.quanta.size(); ++k) {
      const Index i = m.quanta[k];
      Vec3 x1, v1;
      m.at(k, ctx.t + ctx.h, x1, v1);
      out.dx[i] = x1 - state.x[i];
      out.dv[i] = v1 - state.v[i];
    }
  }
}

void place_kinematic(const Model& model, double t, Vec3* x, Vec3* v) {
  for (const Motion& motion : model.motions)
    for (std::size_t k = 0; k < motion.quanta.size(); ++k) motion.at(k, t, x[motion.quanta[k]], v[motion.quanta[k]]);
}

void PrescribedAt::update(const Model& model, double t) {
  list_.clear();
  for (const Motion& motion : model.motions)
    for (std::size_t k = 0; k < motion.quanta.size(); ++k) {
      Quanta& p = list_.emplace_back();
      p.q = motion.quanta[k];
      p.order = static_cast<Index>(list_.size());
      motion.at(k, t, p.x, p.v);
    }
  auto below = [](const Quanta& a, const Quanta& b) { return a.q < b.q; };
  if (std::adjacent_find(list_.begin(), list_.end(), std::not_fn(below)) !=
      list_.end()) {  // not the usual case
    std::sort(list_.begin(), list_.end(), [](const Quanta& a, const Quanta& b) {
      return a.q < b.q || (a.q == b.q && a.order < b.order);
    });
    auto kept = list_.begin();
    for (auto p = list_.begin(); p != list_.end(); ++p)
      if (p + 1 == list_.end() || (p + 1)->q != p->q) *kept++ = *p;  // the last of each quanta's
    list_.erase(kept, list_.end());
  }
  index_.resize(list_.size());
  for (std::size_t k = 0; k < list_.size(); ++k) index_[k] = list_[k].q;
}

std::span<const PrescribedAt::Quanta> PrescribedAt::in(std::size_t lo, std::size_t hi) const {
  const auto a = std::lower_bound(index_.begin(), index_.end(), lo);
  const auto b = std::lower_bound(a, index_.end(), hi);
  return {list_.begin() + (a - index_.begin()), list_.begin() + (b - index_.begin())};
}

void PrescribedAt::project(const State& state, std::size_t lo, std::size_t hi, Projection& out) const {
  for (const Quanta& p : in(lo, hi)) {
    out.dx[p.q] = p.x - state.x[p.q];
    out.dv[p.q] = p.v - state.v[p.q];
  }
}

void PrescribedAt::place(std::size_t lo, std::size_t hi, Vec3* x, Vec3* v) const {
  for (const Quanta& p : in(lo, hi)) {
    x[p.q] = p.x;
    v[p.q] = p.v;
  }
}

namespace {

// The previous step's Δv in a carry-over for n quanta: `previous`'s, or an extrapolated one's
// last (either way, as a checkpoint or a change of warm start may have left it); null if none.
const Vec3* previous_dv(const Carry& carry, std::size_t n) {
  if (const auto* g = std::get_if<SolverGuess>(&carry); g && g->fits(n)) return g->dv.data();
  if (const auto* p = std::get_if<SolverGuessPair>(&carry); p && p->fits(n)) return p->dv.data();
  return nullptr;
}

}  // namespace

WarmStart resolved_warm_start(const IntegratorConfig& config) {
  if (config.warm_start != WarmStart::automatic) return config.warm_start;
  // CG from the line through the last two steps' Δv: fewer iterations wherever Δv changes
  // smoothly from step to step (cube_drop 14.5 a step from zero, 5.9 from the previous Δv, 3.2
  // extrapolated), no more elsewhere; sweeps from such guesses blow up (docs/integrators.md).
  const bool cg = config.type == IntegratorType::coupled_implicit && config.solver == CoupledSolver::cg;
  return cg ? WarmStart::extrapolated : WarmStart::zero;
}

bool initial_guess(WarmStart mode, const Model& model, const std::vector<Vec3>& f_ext, double h,
                   const Carry& carry, int threads, std::vector<Vec3>& y) {
  // No guess fills y for `automatic`: a maker that did not resolve it would start CG from garbage.
  if (mode == WarmStart::automatic) throw std::logic_error("initial_guess: the warm start was not resolved");
  const std::size_t n = model.num_quanta();
  y.resize(n);
  const bool from_previous = mode == WarmStart::previous || mode == WarmStart::extrapolated;
  const Vec3* previous = from_previous ? previous_dv(carry, n) : nullptr;
  const bool zero = mode == WarmStart::zero || (from_previous && !previous);
  const auto* pair = std::get_if<SolverGuessPair>(&carry);
  const Vec3* before = mode == WarmStart::extrapolated && pair && pair->extrapolates(n, h) ? pair->dv_before.data()
                                                                                           : nullptr;
  parallel_for(n, threads, [&](std::size_t i) {
    if (zero || model.is_kinematic(static_cast<Index>(i))) {
      y[i] = Vec3::Zero();
      return;
    }
    switch (mode) {
      case WarmStart::zero: break;
      case WarmStart::external:
        y[i] = (h * model.inv_mass[i]) * external_force(model, f_ext, static_cast<Index>(i));
        break;
      case WarmStart::previous: y[i] = previous[i]; break;
      case WarmStart::extrapolated:
        y[i] = before ? Vec3(2 * previous[i] - before[i]) : previous[i];
        break;
      case WarmStart::automatic: break;  // refused above
    }
  });
  return !zero;
}

void keep_guess(WarmStart mode, const std::vector<Vec3>& y, double h, const Carry& carry, int threads,
                Projection& out) {
  const std::size_t n = y.size();
  if (mode == WarmStart::previous) {
    LineVector<Vec3>& dv = out.keep<SolverGuess>().dv;
    dv.resize(n);
    parallel_for(n, threads, [&](std::size_t i) { dv[i] = y[i]; });
  } else if (mode == WarmStart::extrapolated) {
    const Vec3* previous = previous_dv(carry, n);
    SolverGuessPair& kept = out.keep<SolverGuessPair>();
    kept.dv.resize(n);
    kept.dv_before.resize(n);
    parallel_for(n, threads, [&](std::size_t i) {
      kept.dv[i] = y[i];
      kept.dv_before[i] = previous ? previous[i] : Vec3::Zero();
    });
    // The step before's length: known from an extrapolated carry-over; 0 (never a step's) otherwise.
    const auto* pair = std::get_if<SolverGuessPair>(&carry);
    kept.h = h;
    kept.h_before = pair && pair->fits(n) ? pair->h : 0.0;
  }
}

void TopologyCache::update(const Model& model, const Adjacency& adj) {
  if (adj.version == version && model.num_quanta() == num_quanta && model.motions.size() == motions) return;
  color_free_quanta(model, adj, coloring);
  free_components(model, adj, components);
  version = adj.version;
  num_quanta = model.num_quanta();
  motions = model.motions.size();
}

void restore_component_momentum(const Model& model, const FreeComponents& comps,
                                const std::vector<Vec3>& f_ext, double h, std::vector<Vec3>& dv,
                                const std::vector<std::uint8_t>& skip) {
  for (std::size_t c = 0; c + 1 < comps.offset.size(); ++c) {
    Vec3 wanted = Vec3::Zero(), got = Vec3::Zero();
    bool held = false;
    if (!skip.empty())
      for (Index k = comps.offset[c]; k < comps.offset[c + 1] && !held; ++k) held = skip[comps.quanta[k]] != 0;
    if (held) continue;
    for (Index k = comps.offset[c]; k < comps.offset[c + 1]; ++k) {
      const Index i = comps.quanta[k];
      wanted += h * external_force(model, f_ext, i);
      got += model.mass[i] * dv[i];
    }
    const Vec3 shift = (wanted - got) / comps.mass[c];
    for (Index k = comps.offset[c]; k < comps.offset[c + 1]; ++k) dv[comps.quanta[k]] += shift;
  }
}

void fall_freely(const Model& model, const FreeComponents& comps, const std::vector<Vec3>& f_ext, double h,
                 const std::vector<std::uint8_t>& touching, Projection& out) {
  if (model.gravity == Vec3::Zero()) return;
  for (std::size_t c = 0; c + 1 < comps.offset.size(); ++c)
    if (comps.offset[c + 1] - comps.offset[c] == 1) fall_freely(model, comps.quanta[comps.offset[c]], f_ext, h, touching, out);
}

void fall_freely(const Model& model, Index i, const std::vector<Vec3>& f_ext, double h,
                 const std::vector<std::uint8_t>& touching, Projection& out) {
  if ((touching.empty() || !touching[i]) && (f_ext.empty() || f_ext[i] == model.mass[i] * model.gravity))
    out.dx[i] -= 0.5 * h * h * model.gravity;
}

namespace {

// kinetic_loss's term of quanta q.
double kinetic_term(const Model& model, const Adjacency& adj, const Projection& out, std::size_t q) {
  if (model.is_kinematic(static_cast<Index>(q)) || adj.offset[q] == adj.offset[q + 1]) return 0.0;
  return 0.5 * model.mass[q] * out.dv[q].squaredNorm();
}

double contacts_share(const Projection& out) { return out.contact.charged ? 0.5 * out.contact.impulse_dv : 0.0; }

}  // namespace

double kinetic_loss(const Model& model, const Adjacency& adj, const Projection& out, int threads) {
  return deterministic_sum(model.num_quanta(), threads,
                           [&](std::size_t q) { return kinetic_term(model, adj, out, q); }) -
         contacts_share(out);
}

double kinetic_loss(const Model& model, const Adjacency& adj, const Projection& out, std::span<const Index> quanta) {
  double kinetic = 0;
  for (Index q : quanta) kinetic += kinetic_term(model, adj, out, static_cast<std::size_t>(q));
  return kinetic - contacts_share(out);
}

void write_free_rows(const Model& model, const State& state, double h, const std::vector<Vec3>& dv,
                     int threads, Projection& out) {
  parallel_for(model.num_quanta(), threads, [&](std::size_t i) {
    if (model.is_kinematic(static_cast<Index>(i))) return;
    out.dv[i] = dv[i];
    out.dx[i] = h * (state.v[i] + dv[i]);
  });
}

}  // namespace qbond
