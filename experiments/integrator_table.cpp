// Every integrator on the canonical lattice (the performance workload, docs/performance.md: an
// n³ cubic lattice anchored at x = 0 sagging under gravity, h = 1e-4 s, h·ω_max ≈ 0.6): its cost
// per step and the energy it made or destroyed itself (the energy budget's `numerical_damping` +
// `numerical`, relative to the work gravity did), side by side (docs/integrators.md, "Comparison").
#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include "experiment.hpp"
#include "qbond/analysis/analysis.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/simulation/simulation.hpp"

namespace qbond::experiments {

void integrator_table(const Options& o, Report& rep) {
  rep.paper("every integrator of qbond on its canonical lattice", "");
  const int n = o.fast ? 10 : 40;
  const int steps = o.fast ? 20 : 50;
  auto cfg = [](IntegratorType t) {
    IntegratorConfig c = default_integrator();
    c.type = t;
    return c;
  };
  auto with = [](IntegratorConfig c, auto edit) {
    edit(c);
    return c;
  };
  const std::vector<Method> methods = {
      {"explicit_euler", cfg(IntegratorType::explicit_euler)},
      {"symplectic_euler", cfg(IntegratorType::symplectic_euler)},
      {"velocity_verlet", cfg(IntegratorType::velocity_verlet)},
      {"rk4", cfg(IntegratorType::rk4)},
      {"hybrid_frozen", with(cfg(IntegratorType::hybrid_implicit), [](auto& c) { c.neighbours = NeighbourModel::frozen; })},
      {"hybrid_frozen+restore", with(cfg(IntegratorType::hybrid_implicit), [](auto& c) {
         c.neighbours = NeighbourModel::frozen;
         c.restore_energy = true;
       })},
      {"hybrid_sweep", with(cfg(IntegratorType::hybrid_implicit), [](auto& c) { c.neighbours = NeighbourModel::sweep; })},
      {"coupled_cg (default)", default_integrator()},
      {"coupled_cg+restore", with(default_integrator(), [](auto& c) { c.restore_energy = true; })},
      {"implicit_midpoint", cfg(IntegratorType::implicit_midpoint)},
      {"bdf2", cfg(IntegratorType::bdf2)},
      {"energy_momentum", cfg(IntegratorType::energy_momentum)},
  };
  const Scene scene = canonical_lattice(n);
  rep.note("Canonical lattice " + std::to_string(n) + "³ (" + std::to_string(scene.world.num_quanta()) + " quanta, " +
           std::to_string(scene.world.num_bonds()) + " bonds), h = 1e-4 s, " + std::to_string(steps) +
           " steps from rest under gravity, 1 thread; every solver at its default tolerance (1e-6).");
  rep.note("");
  rep.note("| integrator | ms per step (median) | × default | numerical energy [J] | relative to gravity's work |");
  rep.note("|---|---|---|---|---|");
  rep.table("integrators.csv", "method,ms_per_step,numerical_J,relative_error,gravity_work_J");
  struct Row {
    double ms, numerical, rel;
  };
  std::vector<Row> rows;
  for (const Method& m : methods) {
    rep.progress(m.name);
    IntegratorConfig c = m.config;
    c.threads = 1;
    Simulation sim(scene.world, c, scene.timestep);
    const double g0 = energies(sim.world().model, sim.world().state).gravity;
    std::vector<double> ms;
    for (int k = 0; k < steps; ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      if (sim.step().status != StepReport::Status::ok) break;
      ms.push_back(1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::nth_element(ms.begin(), ms.begin() + static_cast<std::ptrdiff_t>(ms.size() / 2), ms.end());
    const double median = ms.empty() ? NAN : ms[ms.size() / 2];
    const EnergyBudget b = energy_budget(sim.world().model, sim.world().state);
    const double work = g0 - b.now.gravity;  // what gravity gave the sagging lattice
    const double lost = b.integrator_loss();  // numerical_damping (backward Euler's, in closed form) + the rest
    const double rel = std::abs(lost) / work;
    rows.push_back({median, lost, rel});
    rep.row(m.name, {median, lost, rel, work});
  }
  const double base = rows[index_of(methods, "coupled_cg (default)")].ms;
  for (std::size_t k = 0; k < methods.size(); ++k)
    rep.note("| `" + std::string(methods[k].name) + "` | " + num(rows[k].ms, 3) + " | " + num(rows[k].ms / base, 3) +
             " | " + num(rows[k].numerical, 3) + " | " + num(rows[k].rel, 3) + " |");
  auto rel = [&](const char* name) { return rows[index_of(methods, name)].rel; };
  // Claims from the mathematics. Backward Euler dissipates: numerical > 0 and well above the
  // solver tolerance. Restoration closes the budget each step (to the round-off of two energy
  // sums over 10⁵ bonds). The discrete gradient conserves to its Newton tolerance, relative to
  // the step's energy change: far below backward Euler.
  rep.check("backward Euler (coupled, default) loses energy: relative error > 1e-4", rel("coupled_cg (default)") > 1e-4);
  rep.check("restore_energy closes the budget of the default: relative error < 1e-9", rel("coupled_cg+restore") < 1e-9);
  rep.check("restore_energy closes the budget of the frozen hybrid: relative error < 1e-9", rel("hybrid_frozen+restore") < 1e-9);
  rep.check("energy_momentum's error is at least 100x below backward Euler's",
            rel("energy_momentum") * 100 < rel("coupled_cg (default)"));
  rep.check("velocity Verlet (symplectic, second order) beats backward Euler's energy error",
            rel("velocity_verlet") < rel("coupled_cg (default)"));
  rep.value("default_relative_error", rel("coupled_cg (default)"));
  rep.value("energy_momentum_relative_error", rel("energy_momentum"));
  rep.headline("backward Euler (the default) loses " + num(rel("coupled_cg (default)"), 2) +
                   " of gravity's work to numerical dissipation; energy_momentum " +
                   num(rel("energy_momentum"), 2) + "; restore_energy closes the budget",
               "(not in the paper)");
}

}  // namespace qbond::experiments
