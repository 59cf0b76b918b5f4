// Measurements behind the choice of qbond's default integrator (docs/integrators.md).
// Prints Markdown tables; run `build/qbond_integrator_study > table.md`. Wall-clock columns are
// ratios to the coupled sparse-LDLT step measured in the same run (machines are noisy).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "qbond/analysis/analysis.hpp"
#include "qbond/builders/builders.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/simulation/simulation.hpp"

using namespace qbond;

namespace {

struct Candidate {
  std::string name;
  IntegratorConfig cfg;
};

std::vector<Candidate> candidates() {
  auto hybrid = [](NeighbourModel nm, int it, WarmStart ws) {
    IntegratorConfig c;
    c.type = IntegratorType::hybrid_implicit;
    c.neighbours = nm;
    c.iterations = it;
    c.warm_start = ws;
    return c;
  };
  auto coupled = [](CoupledSolver s, WarmStart ws = WarmStart::automatic) {
    IntegratorConfig c;
    c.type = IntegratorType::coupled_implicit;
    c.solver = s;
    c.tolerance = 1e-6;
    c.warm_start = ws;
    return c;
  };
  IntegratorConfig se;
  se.type = IntegratorType::symplectic_euler;
  return {{"symplectic_euler", se},
          {"hybrid frozen (paper)", hybrid(NeighbourModel::frozen, 1, WarmStart::zero)},
          {"hybrid sweep x1, start 0", hybrid(NeighbourModel::sweep, 1, WarmStart::zero)},
          {"hybrid sweep x4, start 0", hybrid(NeighbourModel::sweep, 4, WarmStart::zero)},
          {"hybrid sweep x1, start h f/m", hybrid(NeighbourModel::sweep, 1, WarmStart::external)},
          {"hybrid jacobi x4, start 0", hybrid(NeighbourModel::jacobi, 4, WarmStart::zero)},
          {"coupled ldlt", coupled(CoupledSolver::ldlt)},
          {"coupled cg 1e-6, start 0", coupled(CoupledSolver::cg, WarmStart::zero)},
          {"coupled cg 1e-6, start previous", coupled(CoupledSolver::cg, WarmStart::previous)},
          {"coupled cg 1e-6, start extrapolated (default)", coupled(CoupledSolver::cg)}};
}

World cube(int n, bool anchored, Vec3 gravity) {
  Scene s = canonical_lattice(n);
  if (!anchored) {
    for (std::size_t i = 0; i < s.world.num_quanta(); ++i) s.world.model.inv_mass[i] = 1.0 / s.world.model.mass[i];
    s.world.model.motions.clear();
  }
  s.world.model.gravity = gravity;
  return std::move(s.world);
}

Vec3 mean_velocity(const World& w) {
  Vec3 p = Vec3::Zero();
  double m = 0;
  for (std::size_t i = 0; i < w.num_quanta(); ++i)
    if (!w.model.is_kinematic(static_cast<Index>(i))) {
      p += w.model.mass[i] * w.state.v[i];
      m += w.model.mass[i];
    }
  return p / m;
}

// Runs `steps` steps; returns false on blow-up. `each` sees the simulation after every step.
template <class Each>
bool run(Simulation& sim, long steps, Each each) {
  sim.limits().energy_growth = 1e9;
  for (long n = 0; n < steps; ++n) {
    if (sim.step().status != StepReport::Status::ok) return false;
    each(sim);
  }
  return true;
}
bool run(Simulation& sim, long steps) {
  return run(sim, steps, [](Simulation&) {});
}

std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g", v);
  return b;
}

}  // namespace

int main() {
  const auto cands = candidates();
  const double g = 9.81;
  std::printf("| integrator | free fall v/(g t), h=1e-4 | free fall v/(g t), h=1/60 | thrown: v kept, h=1/60 |"
              " spin: L kept, h=1e-3 | cantilever h·sqrt(k/m)=100: max E/W_g | pendulum 3 s, h=1/60: energy lost / ldlt's |"
              " cost/step vs ldlt (10³, h=1/60) | iterations/step |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  // Baseline cost first (same run, same machine state).
  // Seconds per step (NaN when the run blows up, which makes its timing meaningless).
  auto cost = [&](const IntegratorConfig& cfg, double& its) -> double {
    Simulation sim(cube(10, true, Vec3(0, 0, -g)), cfg, 1.0 / 60);
    sim.set_track_energy(false);
    if (!run(sim, 2)) return NAN;  // also warms up the buffers
    long total = 0;
    const auto t0 = std::chrono::steady_clock::now();
    const int steps = 10;
    if (!run(sim, steps, [&](Simulation& s) { total += s.integrator().stats().iterations; })) return NAN;
    its = static_cast<double>(total) / steps;
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / steps;
  };
  double dummy;
  const double base_cost = cost(cands[6].cfg, dummy);
  // Energy the swinging pendulum loses in 3 s (physical damping plus numerical dissipation) [J].
  auto swing_loss = [&](const IntegratorConfig& cfg) -> double {
    Scene p = builtin_scene("pendulum");
    Simulation sim(std::move(p.world), cfg, 1.0 / 60);
    const double e0 = energies(sim.world().model, sim.world().state).total();
    if (!run(sim, 180)) return NAN;
    return e0 - energies(sim.world().model, sim.world().state).total();
  };
  const double swing_ref = swing_loss(cands[6].cfg);
  for (const Candidate& c : cands) {
    std::vector<std::string> col;
    for (double h : {1e-4, 1.0 / 60}) {
      Simulation sim(cube(6, false, Vec3(0, 0, -g)), c.cfg, h);
      const long steps = h < 1e-3 ? 2000 : 30;
      col.push_back(run(sim, steps) ? fmt(-mean_velocity(sim.world()).z() / (g * steps * h)) : "blow-up");
    }
    {
      World w = cube(6, false, Vec3::Zero());
      for (auto& v : w.state.v) v = Vec3(1, 0, 0);
      Simulation sim(std::move(w), c.cfg, 1.0 / 60);
      col.push_back(run(sim, 30) ? fmt(mean_velocity(sim.world()).x()) : "blow-up");
    }
    {
      World w = cube(6, false, Vec3::Zero());
      const Vec3 omega(0, 0, 10), centre(0.025, 0.025, 0.025);
      for (std::size_t i = 0; i < w.num_quanta(); ++i) w.state.v[i] = omega.cross(w.state.x[i] - centre);
      const double l0 = angular_momentum(w.model, w.state).z();
      Simulation sim(std::move(w), c.cfg, 1e-3);
      col.push_back(run(sim, 200) ? fmt(angular_momentum(sim.world().model, sim.world().state).z() / l0) : "blow-up");
    }
    {
      World w;
      w.model.gravity = Vec3(0, 0, -g);
      CubicLattice lat;
      lat.size = {5, 3, 3};
      lat.bond = {.law = Law::linear, .stiffness = 1000, .damping = 0};
      const auto ids = add_cubic_lattice(w, lat);
      std::vector<Index> face;
      for (Index i : ids)
        if (w.state.x[i].x() == 0.0) face.push_back(i);
      w.prescribe(face, Motion{});
      Simulation sim(std::move(w), c.cfg, 0.1);
      double worst = 0;
      const bool ok = run(sim, 2000, [&](Simulation& s) {
        const Energies e = energies(s.world().model, s.world().state);
        const double work = std::abs(e.gravity - s.world().state.energy.initial_gravity);
        if (work > 0) worst = std::max(worst, (e.kinetic + e.bonds) / work);
      });
      col.push_back(ok ? fmt(worst) : "blow-up");
    }
    {
      const double e = swing_loss(c.cfg);
      col.push_back(std::isnan(e) ? "blow-up" : fmt(e / swing_ref));
    }
    double its = 0;
    const double t = cost(c.cfg, its);
    col.push_back(std::isnan(t) ? "blow-up" : fmt(t / base_cost));
    col.push_back(std::isnan(t) ? "-" : fmt(its));
    std::printf("| %s |", c.name.c_str());
    for (const auto& s : col) std::printf(" %s |", s.c_str());
    std::printf("\n");
  }
  std::printf("\nBaseline: coupled ldlt on the anchored 10x10x10 canonical lattice at h = 1/60 s: %.3g ms per step.\n",
              1e3 * base_cost);
  return 0;
}
