// Drops one quanta for 100 steps of 1 ms and prints the library's version and the final height,
// which must match free fall under the default integrator within its first-order error.
#include <cmath>
#include <cstdio>

#include "qbond/simulation/simulation.hpp"
#include "qbond/version.hpp"

int main() {
  qbond::World world;
  world.model.gravity = {0, 0, -9.81};
  world.add_quanta({0, 0, 1}, {0, 0, 0}, 1e-3);
  qbond::Simulation sim(std::move(world), qbond::default_integrator(), 1e-3);
  for (int k = 0; k < 100; ++k) sim.step();
  const double z = sim.world().state.x[0].z();
  std::printf("qbond %s (headers %s): z = %.6f\n", std::string(qbond::version()).c_str(), QBOND_VERSION, z);
  // Exact: 1 - g t²/2 = 0.95095 at t = 0.1 s; a first-order step is off by g h t / 2 ≈ 5e-4.
  return std::abs(z - (1 - 0.5 * 9.81 * 0.01)) < 1e-3 && qbond::version() == QBOND_VERSION ? 0 : 1;
}
