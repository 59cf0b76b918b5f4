// The `qbond` program. `qbond run` steps the built-in scenes of samples.hpp; scene files and
// outputs come with the scenes issue (README, "Running").
#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>

#include "qbond/analysis.hpp"
#include "qbond/samples.hpp"
#include "qbond/simulation.hpp"

namespace {

struct RunOptions {
  std::string scene;
  long long steps = -1;
  double timestep = -1;
  std::string integrator, neighbours, solver;
  int iterations = -1;
  int every = 0;
  bool list = false;
  bool quiet = false;
};

int run(const RunOptions& o) {
  using namespace qbond;
  if (o.list) {
    for (const Sample& s : samples()) std::printf("%-12s %s\n", s.name.c_str(), s.description.c_str());
    return 0;
  }
  const Sample& sample = o.scene.empty() ? samples().front() : find_sample(o.scene);
  SampleScene scene = sample.build();
  IntegratorConfig cfg = scene.integrator;
  if (!o.integrator.empty()) cfg.type = parse_integrator_type(o.integrator);
  if (!o.neighbours.empty()) cfg.neighbours = parse_neighbour_model(o.neighbours);
  if (!o.solver.empty()) cfg.solver = parse_coupled_solver(o.solver);
  if (o.iterations > 0) cfg.iterations = o.iterations;
  const double h = o.timestep > 0 ? o.timestep : scene.timestep;
  const std::uint64_t steps = o.steps >= 0 ? static_cast<std::uint64_t>(o.steps) : scene.steps;
  Simulation sim(std::move(scene.world), cfg, h);
  const World& w = sim.world();
  if (!o.quiet)
    std::printf("scene %s: %zu quanta, %zu bonds, h = %g s, %llu steps, integrator %s\n", sample.name.c_str(),
                w.num_quanta(), w.num_bonds(), h, static_cast<unsigned long long>(steps),
                std::string(to_string(cfg.type)).c_str());
  const std::uint64_t every = o.every > 0 ? static_cast<std::uint64_t>(o.every) : std::max<std::uint64_t>(1, steps / 10);
  auto print = [&] {
    if (o.quiet) return;
    const EnergyBudget b = energy_budget(w.model, w.state);
    const Vec3 p = linear_momentum(w.model, w.state);
    std::printf("step %8llu  t %9.4f s  kinetic %11.4e  potential %11.4e  total %11.4e  "
                "damping %10.3e  numerical %10.3e  |p| %10.3e\n",
                static_cast<unsigned long long>(w.state.step), w.state.time, b.now.kinetic,
                b.now.bonds + b.now.gravity, b.now.total(), b.dissipated_damping, b.dissipated_numerical,
                p.norm());
  };
  print();
  for (std::uint64_t k = 0; k < steps; ++k) {
    const StepReport r = sim.step();
    if (r.status != StepReport::Status::ok) {
      std::fprintf(stderr, "qbond: %s\n", r.message.c_str());
      return 3;
    }
    if ((k + 1) % every == 0 || k + 1 == steps) print();
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"qbond — the quanta-bond method: deformable, breakable solids, stepped implicitly"};
  app.set_version_flag("--version", std::string("qbond ") + QBOND_VERSION);
  app.require_subcommand(1);
  RunOptions o;
  CLI::App* run_cmd = app.add_subcommand("run", "run a built-in scene (default: the pendulum)");
  run_cmd->add_option("scene", o.scene, "built-in scene name (see --list)");
  run_cmd->add_flag("--list", o.list, "list the built-in scenes");
  run_cmd->add_option("--steps", o.steps, "number of steps (default: the scene's)");
  run_cmd->add_option("--dt", o.timestep, "timestep [s] (default: the scene's)");
  run_cmd->add_option("--integrator", o.integrator, "integrator override");
  run_cmd->add_option("--neighbours", o.neighbours, "hybrid neighbour model: frozen, sweep, jacobi");
  run_cmd->add_option("--solver", o.solver, "coupled solver: dense, ldlt, cg");
  run_cmd->add_option("--iterations", o.iterations, "sweeps per step (hybrid sweep/jacobi)");
  run_cmd->add_option("--every", o.every, "print every N steps");
  run_cmd->add_flag("-q,--quiet", o.quiet, "print nothing but errors");
  try {
    app.parse(argc, argv);
    if (run_cmd->parsed()) return run(o);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "qbond: %s\n", e.what());
    return 2;
  }
  return 0;
}
