#include "qbond/interaction.hpp"

#include <cmath>
#include <numbers>

namespace qbond {

PullSpring make_pull_spring(Index i, const Vec3& target, double mass, double frequency, double zeta) {
  const double w = 2 * std::numbers::pi * frequency;
  const double k = mass * w * w;
  return {i, target, k, 2 * zeta * std::sqrt(k * mass)};
}

double body_mass(const Model& model, Index i) {
  double m = 0;
  for (std::size_t q = 0; q < model.num_quanta(); ++q)
    if (model.body[q] == model.body[i]) m += model.mass[q];
  return m;
}

}  // namespace qbond
