#pragma once
/// Built-in scenes, shared by `qbond run`, the viewer, the benchmarks and the tests (one registry).
#include <functional>
#include <string>
#include <vector>

#include "qbond/integrators.hpp"
#include "qbond/world.hpp"

namespace qbond {

/// A ready-to-run scene: its world, a timestep and a default length.
struct SampleScene {
  World world;
  double timestep = 1e-3;  ///< [s]
  std::uint64_t steps = 1000;
  IntegratorConfig integrator = default_integrator();
};

/// A named entry of the registry.
struct Sample {
  std::string name;
  std::string description;
  std::function<SampleScene()> build;
};

/// All built-in scenes; the first is the default of `qbond run`.
const std::vector<Sample>& samples();
/// The sample of that name; throws std::invalid_argument listing the names when unknown.
const Sample& find_sample(const std::string& name);

/// The performance issue's canonical workload: n×n×n simple-cubic lattice, spacing 0.01 m,
/// 1 g quanta, linear bonds to nearest and face-diagonal neighbours (k = 1000 N/m, axial damping
/// 0.01 N·s/m), x = 0 face anchored, gravity -9.81 m/s² along z, h = 1e-4 s.
SampleScene canonical_lattice(int n);

}  // namespace qbond
