// Eqs. 14–15 (system reduction) and the cantilever: static and low-frequency responses of
// reduced and calibrated spring networks against their exact and continuum solutions.
#include <cmath>
#include <vector>

#include "experiment.hpp"
#include "qbond/laws/materials.hpp"
#include "qbond/simulation/simulation.hpp"
#include "qbond/solvers/statics.hpp"

namespace qbond::experiments {
namespace {

// An anchored chain of bonds k along x with quanta masses m (the last is the carried end) and a
// pull F on the end.
World chain(const std::vector<double>& k, const std::vector<double>& m, double F) {
  World w;
  w.add_quanta(Vec3::Zero(), Vec3::Zero(), 0);
  for (std::size_t b = 0; b < k.size(); ++b) {
    w.add_quanta(Vec3(0.1 * static_cast<double>(b + 1), 0, 0), Vec3::Zero(), m[b]);
    w.add_bond(static_cast<Index>(b), static_cast<Index>(b + 1), {.stiffness = k[b]});
  }
  w.add_load({static_cast<Index>(k.size())}, Vec3(F, 0, 0));
  return w;
}

double stretch_of_end(World w) {
  const double x0 = w.state.x.back().x();
  solve_static(w, 1e-13);
  return w.state.x.back().x() - x0;
}

}  // namespace

void eq14_15(const Options& opt, Report& rep) {
  const std::vector<double> k = {100, 250, 40, 900, 75};
  const double F = 0.5;
  const double ks = series_stiffness(k), kp = parallel_stiffness(k);
  rep.paper("springs in series and in parallel (Eqs. 14-15)",
            "a series of springs can be replaced with a single effective spring using the equation below [...] "
            "the equivalent spring is just the sum of all the springs connected in parallel");
  rep.note("Eq. 14 (series) and Eq. 15 (parallel): bonds of k = 100, 250, 40, 900, 75 N/m, pulled by " + num(F) +
           " N. k_series = " + num(ks, 6) + " N/m, k_parallel = " + num(kp, 6) + " N/m.\n");
  // Statics: the chain, the bundle and their one-bond replacements.
  const double u_chain = stretch_of_end(chain(k, std::vector<double>(k.size(), 1e-3), F));
  const double u_series = stretch_of_end(chain({ks}, {1e-3}, F));
  World bundle;
  bundle.add_quanta(Vec3::Zero(), Vec3::Zero(), 0);
  bundle.add_quanta(Vec3(0.3, 0, 0), Vec3::Zero(), 1);
  for (double kb : k) bundle.add_bond(0, 1, {.stiffness = kb});
  bundle.add_load({1}, Vec3(F, 0, 0));
  const double u_bundle = stretch_of_end(bundle);
  const double u_parallel = stretch_of_end(chain({kp}, {1}, F));
  rep.table("statics.csv", "system,stretch,one_bond_stretch,F_over_k");
  rep.row("series", {u_chain, u_series, F / ks});
  rep.row("parallel", {u_bundle, u_parallel, F / kp});
  rep.check("series: the chain and its Eq. 14 bond stretch alike (" + num(u_chain, 10) + " vs " + num(u_series, 10) +
                " m; F/k_eff = " + num(F / ks, 10) + ")",
            std::abs(u_chain - u_series) < 1e-12 && std::abs(u_series - F / ks) < 1e-12);
  rep.check("parallel: the bundle and its Eq. 15 bond stretch alike (" + num(u_bundle, 10) + " vs " +
                num(u_parallel, 10) + " m)",
            std::abs(u_bundle - u_parallel) < 1e-13);

  // Dynamics: light chain quanta (1 g) carrying a heavy end (1 kg), released from the loaded
  // equilibrium; the reduced bond's end mass takes in the chain's by Rayleigh's rule.
  std::vector<double> m(k.size(), 1e-3);
  m.back() = 1.0;
  World full = chain(k, m, F);
  std::vector<double> rest(k.size()), masses = {0};
  for (std::size_t b = 0; b < k.size(); ++b) {
    rest[b] = full.state.bonds.rest[b];
    masses.push_back(m[b]);
  }
  const ReducedChain red = reduce_chain(k, rest, masses);
  World one = chain({red.stiffness}, {red.end_mass}, F);
  one.state.x[1].x() = full.state.x.back().x();
  one.state.bonds.rest[0] = red.rest_length;
  solve_static(full, 1e-13);
  solve_static(one, 1e-13);
  full.model.loads.clear();
  one.model.loads.clear();
  const double h = 1e-4, period = 2 * M_PI * std::sqrt(red.end_mass / red.stiffness);
  const int steps = static_cast<int>((opt.fast ? 2 : 5) * period / h);
  Simulation a(std::move(full), default_integrator(), h), b(std::move(one), default_integrator(), h);
  rep.table("dynamics.csv", "time,full_end,reduced_end");
  double worst = 0;
  const double amp = F / ks;
  const double x_full = a.world().state.x.back().x() - amp, x_one = b.world().state.x.back().x() - amp;
  for (int n = 1; n <= steps; ++n) {
    a.step();
    b.step();
    const double ua = a.world().state.x.back().x() - x_full, ub = b.world().state.x.back().x() - x_one;
    worst = std::max(worst, std::abs(ua - ub));
    if (n % 20 == 0) rep.row({a.world().state.time, ua, ub});
  }
  rep.note("Free vibration after release: the reduced system's end mass is " + num(red.end_mass, 6) + " kg (1 kg + " +
           num((red.end_mass - 1) * 1e3, 4) + " g of the chain's 4 g by Rayleigh's rule); period " + num(period, 5) +
           " s.\n");
  rep.check("dynamics: the chain's end and the reduced bond's move alike over " + num(steps * h / period, 2) +
                " periods (largest difference " + num(worst / amp * 100, 3) + "% of the amplitude < 1%)",
            worst < 0.01 * amp);
  rep.value("dynamics_difference_percent", worst / amp * 100);
  rep.headline("static stretch identical to 1e-12 m; free vibration within " + num(worst / amp * 100, 2) +
                   "% of the amplitude over " + num(steps * h / period, 2) + " periods",
               "yes");
}

}  // namespace qbond::experiments

namespace qbond::experiments {
namespace {

struct Beam {
  double tip_lattice = 0;   // static tip deflection of the spring network (K u = f) [m]
  double tip_dynamic = 0;   // the default integrator's, relaxed to rest (coarsest only) [m]
  double residual = 0;
  std::size_t quanta = 0;
};

// A steel cantilever of length L and square side b along x, clamped at x = 0 (the first layer of
// quanta anchored), calibrated (E, ρ) at n quanta across; a tip load P down, spread over the
// last layer.
Beam cantilever_beam(int n, double L, double b, double E, double P, bool relax) {
  SteelBar bar = steel_bar(n, L, b, E);
  World& w = bar.world;
  const std::vector<Index>& tip = bar.end;
  w.add_load(tip, Vec3(0, 0, -P));
  auto tip_z = [&](const World& x) {
    double z = 0;
    for (Index i : tip) z += x.state.x[i].z();
    return z / static_cast<double>(tip.size());
  };
  const double z0 = tip_z(w);
  Beam r;
  r.quanta = w.num_quanta();
  World s = w;
  const StaticResult st = solve_static(s, 1e-10);
  r.residual = st.residual;
  r.tip_lattice = z0 - tip_z(s);
  if (relax) {
    // Damped to rest with qbond's default integrator: the dynamics ends where statics says.
    for (std::size_t b2 = 0; b2 < w.num_bonds(); ++b2)
      w.state.bonds.damping[b2] = 0.05 * w.state.bonds.strength[b2] * 1e-4;
    Simulation sim(std::move(w), default_integrator(), 1e-4);
    for (int k = 0; k < 3000; ++k) sim.step();
    r.tip_dynamic = z0 - tip_z(sim.world());
  }
  return r;
}

}  // namespace

void cantilever(const Options& opt, Report& rep) {
  const double L = 0.2, b = 0.02, E = 200e9, P = 100;
  const double nu = lattice_elastic_constants(cubic_cell(Shells::face_diagonal), 1, 1).poisson_ratio;
  const double I = b * b * b * b / 12, A = b * b, G = E / (2 * (1 + nu)), kappa = 10 * (1 + nu) / (12 + 11 * nu);
  const double eb = P * L * L * L / (3 * E * I), timo = eb + P * L / (kappa * G * A);
  rep.paper("a calibrated lattice cantilever against beam theory", "");
  rep.note("A steel cantilever (E = 200 GPa, ρ = 7850 kg/m³; the lattice's ν = " + num(nu) + "), L = " + num(L) +
           " m, square side b = " + num(b) + " m, clamped at x = 0, tip load P = " + num(P) +
           " N. Euler–Bernoulli: δ = P L³/(3 E I) = " + num(eb * 1e6, 5) + " µm; Timoshenko adds P L/(κ G A) with κ = " +
           "10(1+ν)/(12+11ν): δ = " + num(timo * 1e6, 5) + " µm.\n");
  rep.note("| quanta across | quanta | lattice δ [µm] (K u = f) | / Timoshenko | / Euler–Bernoulli | relative residual |");
  rep.note("|---|---|---|---|---|---|");
  const std::vector<int> res = opt.fast ? std::vector<int>{2, 3, 4} : std::vector<int>{4, 8, 16};
  rep.table("deflection.csv", "quanta_across,quanta,lattice,euler_bernoulli,timoshenko");
  std::vector<double> err;
  Beam coarse;
  for (int n : res) {
    rep.progress(std::to_string(n) + " quanta across");
    const Beam r = cantilever_beam(n, L, b, E, P, n == res.front());
    if (n == res.front()) coarse = r;
    err.push_back(std::abs(r.tip_lattice / timo - 1));
    rep.row({static_cast<double>(n), static_cast<double>(r.quanta), r.tip_lattice, eb, timo});
    rep.note("| " + std::to_string(n) + " | " + std::to_string(r.quanta) + " | " + num(r.tip_lattice * 1e6, 5) + " | " +
             num(r.tip_lattice / timo, 4) + " | " + num(r.tip_lattice / eb, 4) + " | " + num(r.residual, 2) + " |");
  }
  rep.note("");
  rep.check("the default integrator, damped to rest, ends at the network's exact static deflection (" +
                num(coarse.tip_dynamic * 1e6, 6) + " vs " + num(coarse.tip_lattice * 1e6, 6) + " µm, within 0.5%)",
            std::abs(coarse.tip_dynamic / coarse.tip_lattice - 1) < 5e-3);
  bool shrinking = true;
  for (std::size_t k = 1; k < err.size(); ++k) shrinking = shrinking && err[k] < err[k - 1];
  rep.check("refining the lattice brings its deflection closer to Timoshenko's (errors " + num(err[0], 3) + " > ... > " +
                num(err.back(), 3) + ")",
            shrinking);
  // Surface quanta miss bonds, so a lattice a few quanta thick is softer (docs/materials.md): the
  // error falls at least as 1/n, the surface layer's share of the section.
  const double n1 = res[res.size() - 2], n2 = res.back();
  const double order = std::log(err[err.size() - 2] / err.back()) / std::log(n2 / n1);
  rep.check("the error falls at least as 1/n (observed order " + num(order, 3) + " between " + num(n1) + " and " +
                num(n2) + " quanta across)",
            order > 0.9);
  if (!opt.fast)
    rep.check("the finest lattice (" + num(n2) + " across) is within 15% of Timoshenko (" + num(err.back() * 100, 3) + "%)",
              err.back() < 0.15);
  else
    rep.inform("the finest lattice is within 15% of Timoshenko (" + num(err.back() * 100, 3) + "% at " + num(n2) +
                   " across)",
               "the fast mode's lattices are too coarse for it; the full run checks it");
  rep.value("order", order);
  rep.value("finest_across", n2);
  rep.value("finest_error_percent", err.back() * 100);
  std::string ratios;
  for (std::size_t k = 0; k < err.size(); ++k) ratios += (k ? ", " : "") + num(1 + err[k], 3);
  rep.headline("tip deflection " + ratios + "× Timoshenko's at " + [&] {
    std::string s;
    for (std::size_t k = 0; k < res.size(); ++k) s += (k ? ", " : "") + std::to_string(res[k]);
    return s;
  }() + " quanta across (error ∝ n^−" + num(order, 3) + "); the default integrator relaxes to the exact network solution",
               "converges to beam theory; coarse lattices are too soft (surface quanta)");
}

}  // namespace qbond::experiments
