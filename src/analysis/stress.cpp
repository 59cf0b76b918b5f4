#include "qbond/analysis/stress.hpp"

#include <cmath>

#include "integrators/bond_forces.hpp"

namespace qbond {

void virial_stress(const Model& model, const State& state, const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                   std::vector<Mat3>& sigma) {
  std::vector<Vec3> force;
  bond_forces(model, state, x, v, 1, force);
  sigma.assign(model.num_quanta(), Mat3::Zero());
  for (std::size_t b = 0; b < state.bonds.size(); ++b) {
    if (!state.bonds.alive[b]) continue;
    const Index i = state.bonds.i[b], j = state.bonds.j[b];
    const Mat3 w = (x[j] - x[i]) * force[b].transpose();
    const Mat3 half_virial = 0.25 * (w + w.transpose());
    if (model.volume[i] > 0) sigma[i] += half_virial / model.volume[i];
    if (model.volume[j] > 0) sigma[j] += half_virial / model.volume[j];
  }
}

void virial_stress(const Model& model, const State& state, std::vector<Mat3>& sigma) {
  virial_stress(model, state, state.x, state.v, sigma);
}

double von_mises(const Mat3& s) {
  const Mat3 dev = s - (s.trace() / 3) * Mat3::Identity();
  return std::sqrt(1.5 * dev.cwiseProduct(dev).sum());
}

Mat3 mean_stress(const Model& model, std::span<const Mat3> sigma, std::span<const Index> quanta) {
  Mat3 sum = Mat3::Zero();
  double volume = 0;
  for (Index i : quanta) {
    sum += model.volume[i] * sigma[i];
    volume += model.volume[i];
  }
  return volume > 0 ? Mat3(sum / volume) : Mat3::Zero();
}

}  // namespace qbond
