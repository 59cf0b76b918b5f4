#pragma once
// The integrators the benchmark programs time, by the names `qbond bench` prints.
#include <string>
#include <vector>

#include "qbond/integrators/integrators.hpp"

namespace qbond::bench {

struct NamedIntegrator {
  std::string name;
  IntegratorConfig config;
};

// hybrid_frozen and hybrid_sweep (the hybrid step, one sweep), velocity_verlet, default, and
// default_multigrid (the default with the multigrid preconditioner).
inline std::vector<NamedIntegrator> known_integrators() {
  IntegratorConfig frozen, sweep, verlet, multigrid = default_integrator();
  multigrid.preconditioner = Preconditioner::multigrid;
  frozen.type = sweep.type = IntegratorType::hybrid_implicit;
  frozen.neighbours = NeighbourModel::frozen;
  sweep.neighbours = NeighbourModel::sweep;
  sweep.iterations = 1;
  sweep.tolerance = 0;
  verlet.type = IntegratorType::velocity_verlet;
  return {{"hybrid_frozen", frozen}, {"hybrid_sweep", sweep}, {"velocity_verlet", verlet}, {"default", default_integrator()},
          {"default_multigrid", multigrid}};
}

}  // namespace qbond::bench
