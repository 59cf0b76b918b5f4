#include "qbond/simulation/interaction.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace qbond {

PullSpring make_pull_spring(const Model& model, Index i, const Vec3& target, double mass, double h, double frequency,
                            double zeta) {
  const double w = 2 * std::numbers::pi * frequency;
  const double m = model.mass[i];
  const double k = std::min(mass * w * w, m / (h * h));
  return {i, target, k, std::min(2 * zeta * std::sqrt(k * mass), m / (2 * h))};
}

double body_mass(const Model& model, Index i) {
  double m = 0;
  for (std::size_t q = 0; q < model.num_quanta(); ++q)
    if (model.body[q] == model.body[i]) m += model.mass[q];
  return m;
}

}  // namespace qbond
