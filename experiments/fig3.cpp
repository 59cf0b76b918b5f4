// Figure 3: time per step against the number of quanta for the hybrid and the coupled implicit
// methods — the paper's chain growing by two bonded quanta per run, and 3D lattices to ~10⁵
// quanta — with the exponent p of a fit t = a + b n^p. Times are the stepping thread's CPU time
// (one thread), so another process's load does not enter them; each point is the fastest of
// three batches of steps. The exponents are checked in the fast mode too.
#include <omp.h>
#include <time.h>

#include <cmath>
#include <vector>

#include "experiment.hpp"
#include "qbond/builders/builders.hpp"
#include "qbond/simulation/simulation.hpp"

namespace qbond::experiments {
namespace {

IntegratorConfig coupled(CoupledSolver s) {
  IntegratorConfig c;
  c.type = IntegratorType::coupled_implicit;
  c.solver = s;
  c.threads = 1;
  return c;
}

IntegratorConfig hybrid(NeighbourModel nm) {
  IntegratorConfig c;
  c.type = IntegratorType::hybrid_implicit;
  c.neighbours = nm;
  c.threads = 1;
  return c;
}

// The calling thread's CPU time [s]: unlike the wall clock, other processes do not add to it.
double thread_seconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Seconds per step: the fastest of three batches, each long enough to time (≥ 20 ms or 1000 steps).
double seconds_per_step(const World& w, const IntegratorConfig& cfg) {
  Simulation sim(w, cfg, 1e-4);
  sim.set_track_energy(false);
  int batch = 1;
  for (;;) {  // grow the batch until it takes 20 ms
    const double t0 = thread_seconds();
    for (int k = 0; k < batch; ++k) sim.step();
    if (thread_seconds() - t0 > 0.02 || batch >= 1000) break;
    batch *= 4;
  }
  double best = INFINITY;
  for (int rep = 0; rep < 3; ++rep) {
    const double t0 = thread_seconds();
    for (int k = 0; k < batch; ++k) sim.step();
    best = std::min(best, (thread_seconds() - t0) / batch);
  }
  return best;
}

// The fit t = a + b g(n) (a, b ≥ 0) minimising the squared relative residuals Σ ((t_k − a − b g(n_k))/t_k)²
// over the points with n ≥ n_min: a is the per-step cost that does not grow with n (set-up, calls).
// The best a, b are a 2×2 weighted linear least-squares problem (weights 1/t²).
struct TwoTermFit {
  double a = 0, b = 0;
  double residual = INFINITY;  // Σ of the squared relative residuals
};
template <class Growth>
TwoTermFit fit_two_terms(const std::vector<double>& n, const std::vector<double>& t, double n_min, Growth g) {
  double s11 = 0, s12 = 0, s22 = 0, r1 = 0, r2 = 0;
  for (std::size_t k = 0; k < n.size(); ++k) {
    if (n[k] < n_min) continue;
    const double w = 1 / (t[k] * t[k]), x = g(n[k]);
    s11 += w, s12 += w * x, s22 += w * x * x, r1 += w * t[k], r2 += w * x * t[k];
  }
  const double det = s11 * s22 - s12 * s12;
  TwoTermFit f{(r1 * s22 - r2 * s12) / det, (s11 * r2 - s12 * r1) / det};
  if (f.a < 0) f = {0, r2 / s22};  // no negative overhead: the pure growth term
  if (f.b <= 0) return {};
  f.residual = 0;
  for (std::size_t k = 0; k < n.size(); ++k) {
    if (n[k] < n_min) continue;
    const double e = (t[k] - f.a - f.b * g(n[k])) / t[k];
    f.residual += e * e;
  }
  return f;
}

// The power law t = a + b nᵖ, p on a grid of 0.001: p is the growth that remains beside a.
struct PowerFit {
  TwoTermFit fit;
  double p = NAN;
};
PowerFit power_fit(const std::vector<double>& n, const std::vector<double>& t, double n_min = 0) {
  PowerFit best;
  for (double p = 0.3; p <= 4.5; p += 0.001) {
    const TwoTermFit f = fit_two_terms(n, t, n_min, [p](double x) { return std::pow(x, p); });
    if (f.residual < best.fit.residual) best = {f, p};
  }
  return best;
}

// The exponential t = a + b e^{cn}, c on a grid of 1e-4: its residual against the power law's
// says which of the two growths the times follow.
double exponential_fit_residual(const std::vector<double>& n, const std::vector<double>& t, double n_min) {
  double best = INFINITY;
  for (double c = 1e-4; c <= 0.2; c += 1e-4)
    best = std::min(best, fit_two_terms(n, t, n_min, [c](double x) { return std::exp(c * x); }).residual);
  return best;
}

World chain(int count) {
  World w;
  w.model.gravity = Vec3(0, 0, -9.81);
  Chain c;
  c.count = count;
  c.end = Vec3(0.01 * (count - 1), 0, 0);
  c.bond = {.stiffness = 1000, .damping = 0.01};
  add_chain(w, c);
  w.prescribe({0}, Motion{});
  return w;
}

World lattice(int n) {
  World w;
  w.model.gravity = Vec3(0, 0, -9.81);
  CubicLattice l;
  l.size = {n, n, n};
  l.bond = {.stiffness = 1000, .damping = 0.01};
  const auto ids = add_cubic_lattice(w, l);
  std::vector<Index> face;
  for (Index i : ids)
    if (w.state.x[i].x() == 0.0) face.push_back(i);
  w.prescribe(face, Motion{});
  return w;
}

}  // namespace

void fig3(const Options& opt, Report& rep) {
  // One thread for everything a step runs, Eigen's dense LU included (its products use OpenMP's
  // default thread count): other threads' CPU time would not be counted.
  const int omp_threads = omp_get_max_threads();
  omp_set_num_threads(1);
  struct Restore {
    int n;
    ~Restore() { omp_set_num_threads(n); }
  } restore{omp_threads};
  rep.paper("a chain grown by two bonded quanta per run, 1000-step averages of the time per step",
            "The results seen in Figure 3 show the exponential increase in time required to perform a timestep with "
            "the coupled implicit method. The hybrid implicit method undergoes a linear increase in computation time. "
            "For a small amount of quanta, the two methods perform about equally");
  rep.note("CPU time per step of the stepping thread (one thread; the fastest of three batches), so other processes' "
           "load does not enter it. The paper's run: a chain (k = 1000 N/m, 1 g quanta, one end anchored, gravity) "
           "grown by two bonded quanta per point; then simple-cubic lattices (face diagonals, one face anchored) toward "
           "10⁵ quanta. Each method's times are fitted by t = a + b nᵖ: a is the cost of a step that does not grow "
           "with n, p the growth.\n");
  // 1. The chain: two quanta added per point (the paper's run) up to the sizes where the dense
  // elimination takes seconds, then, for the methods that scale, growing geometrically.
  const int max_dense = opt.fast ? 240 : 600, max_chain = opt.fast ? 20000 : 100000;
  const std::vector<Method> chain_methods = {{"hybrid_frozen", hybrid(NeighbourModel::frozen)},
                                             {"coupled_dense", coupled(CoupledSolver::dense)},
                                             {"coupled_ldlt", coupled(CoupledSolver::ldlt)},
                                             {"qbond_default", [] {
                                                IntegratorConfig c = default_integrator();
                                                c.threads = 1;
                                                return c;
                                              }()}};
  rep.table("chain.csv", "method,quanta,seconds_per_step");
  std::vector<PowerFit> fit_chain;
  std::vector<double> chain_last_n, chain_last_t, chain_first_t;
  std::vector<double> hybrid_n, hybrid_t;  // the hybrid's points, to compare at the dense method's sizes
  double dense_exponential_residual = NAN;
  int k_method = 0;
  for (const Method& m : chain_methods) {
    rep.progress(std::string("chain, ") + m.name);
    const bool dense = m.config.type == IntegratorType::coupled_implicit && m.config.solver == CoupledSolver::dense;
    // LDLT costs ~10x the other scalable methods on the chain: stop it early to keep the run short.
    const bool ldlt = m.config.type == IntegratorType::coupled_implicit && m.config.solver == CoupledSolver::ldlt;
    std::vector<double> n, t;
    for (int q = 2; q <= (dense ? max_dense : ldlt ? std::min(max_chain, 20000) : max_chain);
         q = q < 20 ? q + 2 : (q < max_dense ? q + max_dense / 12 : 2 * q)) {
      const double s = seconds_per_step(chain(q), m.config);
      n.push_back(q);
      t.push_back(s);
      rep.row(m.name, {static_cast<double>(q), s});
    }
    if (k_method++ == 0) hybrid_n = n, hybrid_t = t;
    // Dense elimination's step also fills a 3n × 3n matrix (∝ n²) and factors it in blocks whose
    // speed still grows with n at the small sizes: its fit takes the sizes from a quarter of the
    // largest, where the factorisation (∝ n³) leads. The other methods' costs have one leading
    // term: every size.
    const double n_min = dense ? n.back() / 4 : 0;
    fit_chain.push_back(power_fit(n, t, n_min));
    if (dense) dense_exponential_residual = exponential_fit_residual(n, t, n_min);
    chain_first_t.push_back(t.front());
    chain_last_n.push_back(n.back());
    chain_last_t.push_back(t.back());
  }
  // 2. Lattices.
  const std::vector<int> sizes = opt.fast ? std::vector<int>{4, 6, 8, 11, 16} : std::vector<int>{4, 6, 8, 11, 16, 22, 32, 46};
  const std::vector<Method> lattice_methods = {{"hybrid_frozen", hybrid(NeighbourModel::frozen)},
                                               {"hybrid_sweep", hybrid(NeighbourModel::sweep)},
                                               {"coupled_cg (default)", chain_methods[3].config},
                                               {"coupled_ldlt", coupled(CoupledSolver::ldlt)}};
  rep.table("lattice.csv", "method,quanta,seconds_per_step");
  std::vector<PowerFit> fit_lattice;
  std::vector<double> lattice_last_n, lattice_last_t;
  for (const Method& m : lattice_methods) {
    rep.progress(std::string("lattices, ") + m.name);
    std::vector<double> n, t;
    for (int s : sizes) {
      // Eigen's simplicial LDLT fills in on 3D lattices: 32³ takes minutes a factorisation and 3 GB.
      if (m.config.solver == CoupledSolver::ldlt && m.config.type == IntegratorType::coupled_implicit &&
          s > (opt.fast ? 11 : 22))
        continue;
      const double sec = seconds_per_step(lattice(s), m.config);
      n.push_back(s * s * s);
      t.push_back(sec);
      rep.row(m.name, {static_cast<double>(s * s * s), sec});
    }
    fit_lattice.push_back(power_fit(n, t));
    lattice_last_n.push_back(n.back());
    lattice_last_t.push_back(t.back());
  }
  rep.note("| run | method | exponent p of t = a + b nᵖ | a (per step) | largest n | time per step there |");
  // (coupled_dense: fitted over the sizes from a quarter of its largest.)
  rep.note("|---|---|---|---|---|---|");
  auto us = [](double s) {  // a duration in the unit that reads best
    return s < 1e-3 ? num(s * 1e6, 3) + " µs" : s < 1 ? num(s * 1e3, 3) + " ms" : num(s, 3) + " s";
  };
  for (std::size_t k = 0; k < chain_methods.size(); ++k) {
    rep.note(std::string("| chain | ") + chain_methods[k].name + " | " + num(fit_chain[k].p, 3) + " | " +
             us(fit_chain[k].fit.a) + " | " + num(chain_last_n[k], 6) + " | " + us(chain_last_t[k]) + " |");
    rep.value(std::string("chain_p_") + chain_methods[k].name, fit_chain[k].p);
    rep.value(std::string("chain_n_") + chain_methods[k].name, chain_last_n[k]);
    rep.value(std::string("chain_t_") + chain_methods[k].name, chain_last_t[k]);
  }
  const char* lattice_keys[] = {"hybrid_frozen", "hybrid_sweep", "qbond_default", "coupled_ldlt"};
  for (std::size_t k = 0; k < lattice_methods.size(); ++k) {
    rep.note(std::string("| lattice | ") + lattice_methods[k].name + " | " + num(fit_lattice[k].p, 3) + " | " +
             us(fit_lattice[k].fit.a) + " | " + num(lattice_last_n[k], 6) + " | " + us(lattice_last_t[k]) + " |");
    rep.value(std::string("lattice_p_") + lattice_keys[k], fit_lattice[k].p);
    rep.value(std::string("lattice_n_") + lattice_keys[k], lattice_last_n[k]);
    rep.value(std::string("lattice_t_") + lattice_keys[k], lattice_last_t[k]);
  }
  rep.value("two_quanta_hybrid_us", chain_first_t[0] * 1e6);
  rep.value("two_quanta_dense_us", chain_first_t[1] * 1e6);
  rep.note("");
  // Tolerance ±0.3 on the linear exponents: under half the gap between the powers the claims tell
  // apart (linear from n^1.5), with room for the memory hierarchy (a working set leaving the caches
  // adds ~0.2 to a linear method's exponent on the full run's lattices) and for the CPU clock's
  // resolution on the smallest points (the fit's a absorbs them). Cubic is told from quadratic and
  // quartic by the nearer power (±0.5), and from exponential by which growth fits the times better.
  const double p_hybrid = fit_chain[0].p, p_dense = fit_chain[1].p, p_lattice = fit_lattice[0].p;
  rep.check("the paper's hybrid costs linear time in the quanta (chain exponent " + num(p_hybrid, 3) +
                ", within 1 ± 0.3)",
            std::abs(p_hybrid - 1) < 0.3);
  const double p_residual = fit_chain[1].fit.residual;
  rep.check("the paper's coupled method (dense elimination) costs cubic time, not exponential (chain exponent " +
                num(p_dense, 3) + ", within 3 ± 0.5; relative residual² " + num(p_residual, 3) +
                " of the power law against " + num(dense_exponential_residual, 3) + " of a + b e^{cn})",
            std::abs(p_dense - 3) < 0.5 && p_residual < dense_exponential_residual);
  rep.check("on lattices the hybrid stays linear (exponent " + num(p_lattice, 3) + ", within 1 ± 0.3)",
            std::abs(p_lattice - 1) < 0.3);
  // "About equally" for few quanta, on the scale of the paper's figure, where the coupled method's
  // cost runs away: the dense/hybrid ratio is within one order of magnitude at 2 quanta, and
  // more than two at the dense method's largest size.
  const double ratio = chain_first_t[1] / chain_first_t[0];
  double hybrid_there = NAN;  // the hybrid's time at the dense method's largest size
  {
    std::size_t k = 0;
    while (k + 1 < hybrid_n.size() && hybrid_n[k] < chain_last_n[1]) ++k;
    hybrid_there = hybrid_t[k];
  }
  const double ratio_large = chain_last_t[1] / hybrid_there;
  rep.check("for 2 quanta the two methods cost about the same on the scale of the figure (" + us(chain_first_t[0]) +
                " hybrid, " + us(chain_first_t[1]) + " dense: ratio " + num(ratio, 3) + " < 10), while at " +
                num(chain_last_n[1], 6) + " quanta the ratio is " + num(ratio_large, 3) + " (> 100)",
            ratio < 10 && ratio_large > 100);
  rep.headline("chain: hybrid exponent " + num(p_hybrid, 3) + ", dense elimination " + num(p_dense, 3) +
                   "; at 2 quanta " + us(chain_first_t[0]) + " vs " + us(chain_first_t[1]) +
                   "; lattices: hybrid " + num(p_lattice, 3) + ", default CG " + num(fit_lattice[2].p, 3) +
                   ", sparse LDLᵀ " + num(fit_lattice[3].p, 3),
               "yes, but the coupled cost is cubic, not exponential, and a modern coupled solver (CG) is near-linear");
}

}  // namespace qbond::experiments
