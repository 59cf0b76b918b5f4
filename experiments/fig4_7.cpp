// Figures 4–7 of the paper: two quanta on one bond against the exact solution (Figs. 4–5), and the
// total energy of four bonded quanta (Figs. 6–7), at a small and a large timestep, for each
// integrator of the paper and qbond's default beside them.
#include <cmath>
#include <vector>

#include "experiment.hpp"
#include "qbond/analysis/analysis.hpp"
#include "qbond/simulation/simulation.hpp"

namespace qbond::experiments {
namespace {

std::vector<Method> figure_methods() {
  auto with = [](IntegratorType t) {
    IntegratorConfig c;
    c.type = t;
    return c;
  };
  IntegratorConfig frozen = with(IntegratorType::hybrid_implicit);
  frozen.neighbours = NeighbourModel::frozen;
  IntegratorConfig dense = with(IntegratorType::coupled_implicit);
  dense.solver = CoupledSolver::dense;
  return {{"explicit_euler", with(IntegratorType::explicit_euler)},
          {"rk4", with(IntegratorType::rk4)},
          {"velocity_verlet", with(IntegratorType::velocity_verlet)},
          {"hybrid_frozen", frozen},
          {"coupled_dense", dense},
          {"qbond_default", default_integrator()}};
}

// Figs. 4–5: m = 1 kg each, k = 100 N/m, L = 1 m, released at rest stretched by s0 = 0.1 m.
// The relative motion is harmonic, ω = √(2k/m): w(t) = −s0 ω sin ωt along the bond.
constexpr double kMass = 1, kStiff = 100, kRest = 1, kStretch = 0.1;

World two_quanta() {
  World w;
  w.add_quanta(Vec3::Zero(), Vec3::Zero(), kMass);
  w.add_quanta(Vec3(kRest + kStretch, 0, 0), Vec3::Zero(), kMass);
  w.add_bond(0, 1, {.stiffness = kStiff, .rest_length = kRest});
  return w;
}

// Amplitude factor per step of each linear scheme on ẍ = −ω² x (undamped), |R(i hω)|, where
// the exact flow has |R| = 1. Explicit Euler √(1 + z²) grows, backward Euler 1/√(1 + z²)
// decays, RK4 |1 + iz − z²/2 − iz³/6 + z⁴/24| is below 1 for z < 2√2, Verlet is 1 (z < 2).
double amplification(const std::string& m, double z) {
  if (m == "explicit_euler") return std::sqrt(1 + z * z);
  if (m == "coupled_dense" || m == "qbond_default") return 1 / std::sqrt(1 + z * z);
  if (m == "rk4") return std::hypot(1 - z * z / 2 + z * z * z * z / 24, z - z * z * z / 6);
  if (m == "velocity_verlet") return z < 2 ? 1.0 : NAN;
  return NAN;  // the frozen hybrid is not a fixed linear scheme of the relative motion
}

}  // namespace

void fig4_5(const Options&, Report& rep) {
  const double omega = std::sqrt(2 * kStiff / kMass), period = 2 * M_PI / omega;
  const double amp = kStretch * omega;
  rep.paper("two quanta connected by a single bond, relative velocity against the exact solution (Figures 4-5)",
            "While there is a phase shift present in both methods, the amplitude and period of the solutions match the "
            "exact solution precisely. Sufficiently small timesteps cause the solutions from both the coupled and hybrid "
            "methods to be nearly identical. However, a large timestep causes the hybrid method to produce less accurate "
            "results, while the coupled method continues to be accurate.");
  rep.note("Two quanta of " + num(kMass) + " kg on one linear bond (k = " + num(kStiff) + " N/m, L = " + num(kRest) +
           " m), released stretched by " + num(kStretch) + " m: the relative velocity is w(t) = -s0 ω sin ωt, ω = " +
           num(omega) + " rad/s (period " + num(period) + " s).\n");
  struct Case {
    const char* name;
    double h;
  };
  const Case cases[] = {{"small", 1e-3}, {"large", 0.25}};
  // Two periods in both modes (the run is cheap): backward Euler's decay compounds, so how closely
  // "tracks" holds depends on the length of the run (4 periods at h = 1e-3 take 16% of the amplitude).
  const int periods = 2;
  rep.note("| timestep | h ω | method | RMS error / amplitude | last peak / exact amplitude | amplification theory |");
  rep.note("|---|---|---|---|---|---|");
  std::vector<std::vector<double>> rms(2);
  double worst_theory = 0;
  for (int c = 0; c < 2; ++c) {
    const double h = cases[c].h;
    const int steps = static_cast<int>(std::ceil(periods * period / h));
    const std::string fig = c == 0 ? "4" : "5";
    rep.table("fig" + fig + "_exact.csv", "time,relative_velocity");
    for (int k = 0; k <= 100 * periods; ++k) {
      const double t = k * period / 100;
      if (t <= steps * h) rep.row({t, -amp * std::sin(omega * t)});
    }
    rep.table("fig" + fig + "_velocity.csv", "method,time,relative_velocity,exact");
    for (const Method& m : figure_methods()) {
      Simulation sim(two_quanta(), m.config, h);
      sim.set_keep_last_good(false);
      double err2 = 0, last_peak = 0, t_peak = 0;
      bool blew_up = false;
      for (int n = 1; n <= steps; ++n) {
        const StepReport r = sim.step();
        const State& s = sim.world().state;
        const double w = s.v[1].x() - s.v[0].x();
        const double exact = -amp * std::sin(omega * s.time);
        if (r.status != StepReport::Status::ok || !std::isfinite(w) || std::abs(w) > 1e3 * amp) {
          blew_up = true;
          break;
        }
        err2 += (w - exact) * (w - exact);
        if (s.time > (periods - 1) * period && std::abs(w) > last_peak) {
          last_peak = std::abs(w);
          t_peak = s.time;
        }
        rep.row(m.name, {s.time, w, exact});
      }
      const double e = blew_up ? INFINITY : std::sqrt(err2 / steps) / amp;
      rms[c].push_back(e);
      // The linear schemes' amplitude at the last peak's time, against the exact flow's.
      const double theory = std::pow(amplification(m.name, h * omega), t_peak / h);
      if (c == 0 && !std::isnan(theory)) worst_theory = std::max(worst_theory, std::abs(last_peak / amp / theory - 1));
      rep.note(std::string("| ") + cases[c].name + " " + num(h) + " s | " + num(h * omega, 3) + " | " + m.name + " | " +
               (blew_up ? "blew up" : num(e, 3)) + " | " + (blew_up ? "-" : num(last_peak / amp, 4)) + " | " +
               (std::isnan(theory) ? "-" : num(theory, 4)) + " |");
    }
  }
  rep.note("");
  const auto ms = figure_methods();
  const auto fe = index_of(ms, "explicit_euler"), rk = index_of(ms, "rk4"), fr = index_of(ms, "hybrid_frozen"),
             cd = index_of(ms, "coupled_dense"), qd = index_of(ms, "qbond_default");
  rep.check("small step: the paper's implicit methods (hybrid, coupled) and qbond's track the exact solution (RMS "
            "error < 5% of the amplitude: " + num(rms[0][fr], 3) + ", " + num(rms[0][cd], 3) + ", " + num(rms[0][qd], 3) + ")",
            rms[0][fr] < 0.05 && rms[0][cd] < 0.05 && rms[0][qd] < 0.05);
  rep.check("small step: explicit Euler, RK4, Verlet and backward Euler (the coupled method) grow or decay exactly as "
            "their amplification factors predict (worst relative difference " + num(worst_theory, 2) + " < 0.5%)",
            worst_theory < 5e-3);
  rep.check("small step: hybrid and coupled are nearly identical (RMS errors within 2x of each other: " +
                num(rms[0][fr], 3) + " vs " + num(rms[0][cd], 3) + ")",
            rms[0][fr] < 2 * rms[0][cd] && rms[0][cd] < 2 * rms[0][fr]);
  rep.check("large step: explicit Euler and RK4 blow up or lose the solution (RMS error > 100%: " + num(rms[1][fe], 3) +
                ", " + num(rms[1][rk], 3) + ")",
            rms[1][fe] > 1 && rms[1][rk] > 1);
  rep.check("large step: the implicit methods stay bounded (finite RMS error, the solution decays instead of growing)",
            std::isfinite(rms[1][fr]) && std::isfinite(rms[1][cd]) && rms[1][fr] <= 1.5 && rms[1][cd] <= 1.5);
  rep.check("large step: the hybrid is less accurate than the coupled method (RMS " + num(rms[1][fr], 3) + " vs " +
                num(rms[1][cd], 3) + "), as the paper reports",
            rms[1][fr] > rms[1][cd]);
  for (int c = 0; c < 2; ++c)
    for (std::size_t k = 0; k < ms.size(); ++k)
      rep.value(std::string(c == 0 ? "small_rms_" : "large_rms_") + ms[k].name, rms[c][k]);
  rep.value("worst_theory", worst_theory);
  rep.value("h_omega_large", cases[1].h * omega);
  // Backward Euler's amplitude factor per step and over the run: 1/√(1 + h²ω²) and its power.
  rep.value("be_factor_large", 1 / std::sqrt(1 + std::pow(cases[1].h * omega, 2)));
  rep.value("be_loss_small_4_periods", std::pow(1 + std::pow(cases[0].h * omega, 2), -0.5 * 4 * period / cases[0].h));
  rep.headline("RMS error " + num(100 * rms[0][fr], 2) + "% (hybrid) and " + num(100 * rms[0][cd], 2) +
                   "% (coupled) over two periods at h = 1 ms; " + num(100 * rms[1][fr], 2) + "% vs " +
                   num(100 * rms[1][cd], 2) + "% at h = 0.25 s",
               "yes; but \"the amplitude and period ... match the exact solution precisely\" does not hold: backward "
               "Euler loses 1 − (1 + h²ω²)^(−n/2) of the amplitude, exactly; and at the large step the coupled method is "
               "stable, not accurate");
}

namespace {

// Figs. 6–7: four quanta, every pair bonded (a tetrahedron of 6 bonds), given initial velocities
// with a net momentum. The total energy E(t) with each method.
World four_quanta() {
  World w;
  const double a = 1;
  const Vec3 p[4] = {{0, 0, 0}, {a, 0, 0}, {0.5 * a, 0.866 * a, 0}, {0.5 * a, 0.289 * a, 0.816 * a}};
  const Vec3 v[4] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-0.5, 0.5, 0}};
  for (int q = 0; q < 4; ++q) w.add_quanta(p[q], v[q], 1.0);
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) w.add_bond(i, j, {.stiffness = kStiff});
  return w;
}

}  // namespace

void fig6_7(const Options&, Report& rep) {
  World w0 = four_quanta();
  const double E0 = energies(w0.model, w0.state).total();
  const Vec3 P = linear_momentum(w0.model, w0.state);
  const double E_cm = 0.5 * P.squaredNorm() / 4.0;
  rep.paper("four quanta, each bonded to the others, given initial velocities (Figures 6-7)",
            "Again, with a small enough timestep, the solutions were nearly identical and perfectly stable. When a large "
            "timestep was used, the coupled and hybrid implicit methods stabilized at nearly the same level just as "
            "rapidly. This is interesting, since when a simple system is simulated, the hybrid method stabilizes at "
            "near zero levels of energy extremely rapidly, while the coupled implicit method stabilizes at non-zero "
            "levels of energy after a long period of time.");
  rep.note("Four quanta of 1 kg, every pair bonded (k = " + num(kStiff) +
           " N/m, no damping), given initial velocities with a net momentum: E(0) = " + num(E0) +
           " J, of which the centre of mass carries " + num(E_cm) + " J (a Galilean-invariant method keeps it).\n");
  // 20 s in both modes (the run is cheap): the two implicit methods drift apart over time, so
  // whether they look "nearly identical" depends on the length of the run (1.35x apart after 5 s).
  const double duration = 20;
  struct Case {
    const char* name;
    double h;
  };
  const Case cases[] = {{"small", 1e-3}, {"large", 0.1}};
  rep.note("| timestep | method | E(end) / E(0) | max E / E(0) |");
  rep.note("|---|---|---|---|");
  std::vector<std::vector<double>> end(2), peak(2);
  for (int c = 0; c < 2; ++c) {
    const double h = cases[c].h;
    const int steps = static_cast<int>(std::round(duration / h));
    const int every = std::max(1, steps / 1000);
    rep.table(std::string("fig") + (c == 0 ? "6" : "7") + "_energy.csv", "method,time,total_energy");
    for (const Method& m : figure_methods()) {
      Simulation sim(four_quanta(), m.config, h);
      sim.set_keep_last_good(false);
      double E = E0, Emax = E0;
      rep.row(m.name, {0.0, E0});
      for (int n = 1; n <= steps; ++n) {
        if (sim.step().status != StepReport::Status::ok) {
          E = INFINITY;
          break;
        }
        E = energies(sim.world().model, sim.world().state).total();
        Emax = std::max(Emax, E);
        if (!std::isfinite(E) || E > 1e6 * E0) {
          E = INFINITY;
          break;
        }
        if (n % every == 0) rep.row(m.name, {sim.world().state.time, E});
      }
      end[c].push_back(E / E0);
      peak[c].push_back(Emax / E0);
      rep.note(std::string("| ") + cases[c].name + " " + num(h) + " s | " + m.name + " | " +
               (std::isfinite(E) ? num(E / E0, 4) : "blew up") + " | " + (std::isfinite(E) ? num(Emax / E0, 4) : "-") + " |");
    }
  }
  rep.note("");
  const auto ms = figure_methods();
  const auto fe = index_of(ms, "explicit_euler"), vv = index_of(ms, "velocity_verlet"),
             fr = index_of(ms, "hybrid_frozen"), cd = index_of(ms, "coupled_dense"), qd = index_of(ms, "qbond_default");
  const double cm = E_cm / E0;
  rep.check("small step: velocity Verlet conserves energy (max drift " + num(peak[0][vv] - 1, 3) + " < 1e-3)",
            std::abs(peak[0][vv] - 1) < 1e-3 && std::abs(end[0][vv] - 1) < 1e-3);
  rep.check("small step: explicit Euler gains energy (E(end)/E(0) = " + num(end[0][fe], 4) + " > 1)", end[0][fe] > 1);
  rep.check("small step: the implicit methods never gain energy (max E/E(0) = " + num(peak[0][fr], 6) + ", " +
                num(peak[0][cd], 6) + ", " + num(peak[0][qd], 6) + " <= 1)",
            peak[0][fr] <= 1 + 1e-12 && peak[0][cd] <= 1 + 1e-12 && peak[0][qd] <= 1 + 1e-9);
  rep.check("large step: explicit Euler blows up", !std::isfinite(end[1][fe]));
  rep.check("large step: the implicit methods are stable (E never above E(0): " + num(peak[1][fr], 6) + ", " +
                num(peak[1][cd], 6) + ")",
            peak[1][fr] <= 1 + 1e-12 && peak[1][cd] <= 1 + 1e-12);
  // The paper's claims for these four quanta ("nearly identical" at the small step, "at nearly the
  // same level" at the large one) are tested as stated: two levels are "nearly the same" when
  // they agree within a factor 2 (the criterion Figures 4-5 use for "nearly identical"); qbond
  // finds them apart, and says so with a check that fails if the run ever shows them alike.
  const double small_ratio = end[0][cd] / end[0][fr];
  rep.check("small step: the paper's \"nearly identical\" does not hold for these four quanta: after " +
                num(duration) + " s the hybrid keeps " + num(end[0][fr], 3) + " of E(0), the coupled method " +
                num(end[0][cd], 3) + " (" + num(small_ratio, 3) + "x apart, more than 2x)",
            small_ratio > 2);
  rep.check("large step: the paper's \"at nearly the same level\" does not hold for these four quanta: the hybrid "
            "settles near zero (E(end)/E(0) = " + num(end[1][fr], 3) + " < 0.05; its drag even stops the centre of mass, "
            "whose share is " + num(cm, 3) + "), the coupled method at a non-zero level, at least the centre of mass "
            "motion it keeps (" + num(end[1][cd], 3) + " >= 0.95 x " + num(cm, 3) + ")",
            end[1][fr] < 0.05 && end[1][cd] >= 0.95 * cm && end[1][cd] < 1);
  rep.value("duration", duration);
  rep.value("E0", E0);
  rep.value("cm_share", cm);
  for (int c = 0; c < 2; ++c)
    for (std::size_t k = 0; k < ms.size(); ++k) {
      rep.value(std::string(c == 0 ? "small_end_" : "large_end_") + ms[k].name, end[c][k]);
      rep.value(std::string(c == 0 ? "small_max_" : "large_max_") + ms[k].name, peak[c][k]);
    }
  rep.value("verlet_drift", peak[0][vv] - 1);
  rep.headline("never above E(0) at either step; E(end)/E(0) after " + num(duration) + " s: hybrid " +
                   num(end[0][fr], 3) + " vs coupled " + num(end[0][cd], 3) + " at h = 1 ms, " + num(end[1][fr], 3) +
                   " vs " + num(end[1][cd], 3) + " at h = 0.1 s",
               "stable, as the paper says; not \"nearly identical\" nor \"at nearly the same level\": on four quanta "
               "qbond sees what the paper reports for a simpler system (the hybrid near zero, the coupled method at "
               "the centre of mass's share and above)");
}

}  // namespace qbond::experiments
