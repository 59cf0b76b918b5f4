#include <algorithm>
#include <array>
#include <cassert>
#include <functional>
#include <stdexcept>
#include <string>

#include "integrators/integrator_common.hpp"
#include "integrators/prescribed.hpp"
#include "core/parallel.hpp"

namespace qbond {

IntegratorConfig default_integrator() {
  IntegratorConfig c;  // the struct's defaults are the shipped defaults; see docs/integrators.md
  return c;
}

std::unique_ptr<Integrator> make_integrator(const IntegratorConfig& config) {
  return make_step_integrator(config);
}

std::unique_ptr<StepIntegrator> make_step_integrator(const IntegratorConfig& config) {
  IntegratorConfig c = config;
  // CG from the line through the last two steps' Δv: fewer iterations wherever Δv changes
  // smoothly from step to step (cube_drop 14.5 a step from zero, 5.9 from the previous Δv, 3.2
  // extrapolated), no more elsewhere; sweeps from such guesses blow up (docs/integrators.md).
  if (c.warm_start == WarmStart::automatic) {
    const bool cg = c.type == IntegratorType::coupled_implicit && c.solver == CoupledSolver::cg;
    c.warm_start = cg ? WarmStart::extrapolated : WarmStart::zero;
  }
  if (c.iterations < 1) throw std::invalid_argument("integrator.iterations: must be >= 1");
  if (c.threads < 0) throw std::invalid_argument("integrator.threads: must be >= 0 (0: all cores)");
  if (c.max_iterations < 0) throw std::invalid_argument("integrator.max_iterations: must be >= 0");
  if (!(c.tolerance >= 0)) throw std::invalid_argument("integrator.tolerance: must be >= 0");
  if (!(c.chebyshev_rho >= 0 && c.chebyshev_rho < 1))
    throw std::invalid_argument("integrator.chebyshev_rho: must be in [0, 1)");
  switch (c.type) {
    case IntegratorType::explicit_euler:
    case IntegratorType::symplectic_euler:
    case IntegratorType::velocity_verlet:
    case IntegratorType::rk4:
      return make_explicit_integrator(c);
    case IntegratorType::hybrid_implicit:
      return make_hybrid_integrator(c);
    case IntegratorType::coupled_implicit:
      if (c.solver == CoupledSolver::sweep)
        throw std::invalid_argument(
            "integrator.solver: 'sweep' is for the Newton integrators; coupled_implicit with sweeps is "
            "hybrid_implicit with neighbours 'sweep'");
      return make_coupled_implicit_integrator(c);
    case IntegratorType::energy_momentum:
    case IntegratorType::implicit_midpoint:
    case IntegratorType::bdf2:
      if (c.newton_iterations < 1) throw std::invalid_argument("integrator.newton_iterations: must be >= 1");
      if (c.type == IntegratorType::bdf2 && c.warm_start == WarmStart::previous)
        throw std::invalid_argument(
            "integrator.warm_start: 'previous' is not available with bdf2 (its carry-over is the previous state)");
      if (c.warm_start == WarmStart::extrapolated)
        throw std::invalid_argument(
            "integrator.warm_start: 'extrapolated' is for hybrid_implicit and coupled_implicit (a Newton "
            "integrator's substeps have no previous steps of their length)");
      return make_newton_integrator(c);
  }
  throw std::invalid_argument("unknown integrator type");
}

namespace {
template <class E, std::size_t N>
E parse_name(std::string_view s, const std::array<E, N>& all, const char* what) {
  std::string names;
  for (E e : all) {
    if (to_string(e) == s) return e;
    names += (names.empty() ? "" : ", ") + std::string(to_string(e));
  }
  throw std::invalid_argument(std::string("unknown ") + what + " '" + std::string(s) +
                              "' (expected one of: " + names + ")");
}
}  // namespace

std::string_view to_string(IntegratorType t) {
  switch (t) {
    case IntegratorType::explicit_euler: return "explicit_euler";
    case IntegratorType::symplectic_euler: return "symplectic_euler";
    case IntegratorType::velocity_verlet: return "velocity_verlet";
    case IntegratorType::rk4: return "rk4";
    case IntegratorType::hybrid_implicit: return "hybrid_implicit";
    case IntegratorType::coupled_implicit: return "coupled_implicit";
    case IntegratorType::energy_momentum: return "energy_momentum";
    case IntegratorType::implicit_midpoint: return "implicit_midpoint";
    case IntegratorType::bdf2: return "bdf2";
  }
  return "?";
}
std::string_view to_string(NeighbourModel m) {
  switch (m) {
    case NeighbourModel::frozen: return "frozen";
    case NeighbourModel::sweep: return "sweep";
    case NeighbourModel::jacobi: return "jacobi";
  }
  return "?";
}
std::string_view to_string(CoupledSolver s) {
  switch (s) {
    case CoupledSolver::dense: return "dense";
    case CoupledSolver::ldlt: return "ldlt";
    case CoupledSolver::cg: return "cg";
    case CoupledSolver::sweep: return "sweep";
  }
  return "?";
}
std::string_view to_string(WarmStart w) {
  switch (w) {
    case WarmStart::zero: return "zero";
    case WarmStart::external: return "external";
    case WarmStart::previous: return "previous";
    case WarmStart::automatic: return "auto";
    case WarmStart::extrapolated: return "extrapolated";
  }
  return "?";
}

IntegratorType parse_integrator_type(std::string_view s) {
  return parse_name(s,
                    std::array{IntegratorType::explicit_euler, IntegratorType::symplectic_euler,
                               IntegratorType::velocity_verlet, IntegratorType::rk4,
                               IntegratorType::hybrid_implicit, IntegratorType::coupled_implicit,
                               IntegratorType::energy_momentum, IntegratorType::implicit_midpoint,
                               IntegratorType::bdf2},
                    "integrator");
}
NeighbourModel parse_neighbour_model(std::string_view s) {
  return parse_name(s, std::array{NeighbourModel::frozen, NeighbourModel::sweep, NeighbourModel::jacobi},
                    "neighbour model");
}
CoupledSolver parse_coupled_solver(std::string_view s) {
  return parse_name(s, std::array{CoupledSolver::dense, CoupledSolver::ldlt, CoupledSolver::cg, CoupledSolver::sweep},
                    "solver");
}
WarmStart parse_warm_start(std::string_view s) {
  constexpr std::array all{WarmStart::zero, WarmStart::external, WarmStart::previous, WarmStart::automatic,
                           WarmStart::extrapolated};
  return parse_name(s, all, "warm start");
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

bool initial_guess(WarmStart mode, const Model& model, const std::vector<Vec3>& f_ext, double h,
                   const Carry& carry, int threads, std::vector<Vec3>& y) {
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
      case WarmStart::automatic: assert(false && "make_integrator resolves it"); break;
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
  if (adj.version == version && model.num_quanta() == num_quanta) return;
  color_free_quanta(model, adj, coloring);
  free_components(model, adj, components);
  version = adj.version;
  num_quanta = model.num_quanta();
}

void restore_component_momentum(const Model& model, const FreeComponents& comps,
                                const std::vector<Vec3>& f_ext, double h, std::vector<Vec3>& dv) {
  for (std::size_t c = 0; c + 1 < comps.offset.size(); ++c) {
    Vec3 wanted = Vec3::Zero(), got = Vec3::Zero();
    for (Index k = comps.offset[c]; k < comps.offset[c + 1]; ++k) {
      const Index i = comps.quanta[k];
      wanted += h * external_force(model, f_ext, i);
      got += model.mass[i] * dv[i];
    }
    const Vec3 shift = (wanted - got) / comps.mass[c];
    for (Index k = comps.offset[c]; k < comps.offset[c + 1]; ++k) dv[comps.quanta[k]] += shift;
  }
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
