#pragma once
// The integrators the benchmark programs time, by the names `qbond bench` prints.
#include <string>
#include <vector>

#include "qbond/integrators/integrators.hpp"

namespace qbond::bench {

struct NamedIntegrator {
  std::string name;
  IntegratorConfig config;
  double timestep = 0;  ///< [s] the step it is timed at; 0: the workload's (h = 1e-4 s)
};

// Every integrator with its scene defaults; the hybrid as hybrid_frozen and hybrid_sweep (one
// sweep), the coupled step as default (CG), default_multigrid (CG with the multigrid
// preconditioner) and coupled_ldlt. The first four are the rows timed
// when none are named.
inline std::vector<NamedIntegrator> known_integrators() {
  auto of = [](IntegratorType t) {
    IntegratorConfig c;
    c.type = t;
    return c;
  };
  IntegratorConfig frozen = of(IntegratorType::hybrid_implicit), sweep = frozen;
  frozen.neighbours = NeighbourModel::frozen;
  sweep.neighbours = NeighbourModel::sweep;
  sweep.iterations = 1;
  sweep.tolerance = 0;
  IntegratorConfig ldlt = of(IntegratorType::coupled_implicit);
  ldlt.solver = CoupledSolver::ldlt;
  IntegratorConfig multigrid = default_integrator();
  multigrid.preconditioner = Preconditioner::multigrid;
  return {{"hybrid_frozen", frozen},
          {"hybrid_sweep", sweep},
          {"velocity_verlet", of(IntegratorType::velocity_verlet)},
          {"default", default_integrator()},
          // Forward Euler grows an undamped mode at any step: at 1e-4 s the lattice blows up within
          // the timed steps; at 1e-6 s it stays bounded for far longer than a benchmark runs.
          {"default_multigrid", multigrid},
          {"explicit_euler", of(IntegratorType::explicit_euler), 1e-6},
          {"symplectic_euler", of(IntegratorType::symplectic_euler)},
          {"rk4", of(IntegratorType::rk4)},
          {"coupled_ldlt", ldlt},
          {"energy_momentum", of(IntegratorType::energy_momentum)},
          {"implicit_midpoint", of(IntegratorType::implicit_midpoint)},
          {"bdf2", of(IntegratorType::bdf2)}};
}

// The rows timed when --integrators is not given.
inline constexpr std::size_t kDefaultRows = 4;

}  // namespace qbond::bench
