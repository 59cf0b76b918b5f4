#include "integrators/energy_restore.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace qbond {

namespace {
Index find(std::vector<Index>& parent, Index i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}
}  // namespace

MotionComponents motion_components(const Model& model, const Adjacency& adj) {
  const std::size_t n = model.num_quanta();
  std::vector<Index> parent(n);
  std::iota(parent.begin(), parent.end(), Index{0});
  std::vector<std::uint8_t> anchored(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (model.is_kinematic(static_cast<Index>(i))) continue;
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
      const Index j = adj.other[e];
      if (model.is_kinematic(j)) {
        anchored[i] = 1;
        continue;
      }
      const Index a = find(parent, static_cast<Index>(i)), b = find(parent, j);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);  // the smallest id is the root: deterministic
    }
  }
  MotionComponents c;
  c.of.assign(n, kNone);
  for (std::size_t i = 0; i < n; ++i) {
    if (model.is_kinematic(static_cast<Index>(i))) continue;
    const Index r = find(parent, static_cast<Index>(i));
    if (r == i) {
      c.of[i] = static_cast<Index>(c.anchored.size());
      c.anchored.push_back(0);
    } else {
      c.of[i] = c.of[r];  // r < i: numbered already
    }
    c.anchored[c.of[i]] |= anchored[i];
  }
  return c;
}

InternalScaling scale_internal_velocities(const Model& model, std::span<const Index> quanta,
                                          std::span<const Index> component, std::span<const std::uint8_t> anchored,
                                          State& state, double delta_kinetic,
                                          const std::function<void(std::span<double>)>& add) {
  // Per component: mass, Σ m x, momentum (7 sums), then angular momentum and inertia about the
  // centre (12), each summed over the quanta in their order, then over the parts.
  const std::size_t nc = anchored.size();
  std::vector<double> first(7 * nc, 0.0), second(12 * nc, 0.0);
  for (std::size_t k = 0; k < quanta.size(); ++k) {
    const Index i = quanta[k];
    const double m = model.mass[i];
    double* s = &first[7 * component[k]];
    s[0] += m;
    Eigen::Map<Vec3>(s + 1) += m * state.x[i];
    Eigen::Map<Vec3>(s + 4) += m * state.v[i];
  }
  add(first);
  std::vector<Vec3> centre(nc), velocity(nc), spin(nc, Vec3::Zero());
  for (std::size_t c = 0; c < nc; ++c) {
    const double* s = &first[7 * c];
    centre[c] = Eigen::Map<const Vec3>(s + 1) / s[0];
    velocity[c] = Eigen::Map<const Vec3>(s + 4) / s[0];
  }
  for (std::size_t k = 0; k < quanta.size(); ++k) {
    const Index i = quanta[k], c = component[k];
    if (anchored[c]) continue;
    const double m = model.mass[i];
    const Vec3 r = state.x[i] - centre[c];
    double* s = &second[12 * c];
    Eigen::Map<Vec3>(s) += m * r.cross(state.v[i] - velocity[c]);
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(s + 3) +=
        m * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
  }
  add(second);
  for (std::size_t c = 0; c < nc; ++c) {
    if (anchored[c]) continue;
    const double* s = &second[12 * c];
    const Mat3 inertia = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(s + 3);
    // A collinear component has a singular inertia: its rotation about the line carries no energy.
    spin[c] = inertia.completeOrthogonalDecomposition().solve(Vec3(Eigen::Map<const Vec3>(s)));
  }
  auto internal = [&](std::size_t k) -> Vec3 {
    const Index i = quanta[k], c = component[k];
    return anchored[c] ? state.v[i] : Vec3(state.v[i] - velocity[c] - spin[c].cross(state.x[i] - centre[c]));
  };
  double k_internal[1] = {0};
  for (std::size_t k = 0; k < quanta.size(); ++k) k_internal[0] += 0.5 * model.mass[quanta[k]] * internal(k).squaredNorm();
  add(k_internal);
  if (!(k_internal[0] > 0)) return {};
  const double lambda = std::sqrt(std::clamp(1 + delta_kinetic / k_internal[0], 0.0, 100.0));
  for (std::size_t k = 0; k < quanta.size(); ++k) state.v[quanta[k]] += (lambda - 1) * internal(k);
  return {.lambda = lambda, .internal_kinetic = k_internal[0]};
}

double scale_internal_velocities(const Model& model, const Adjacency& adj, State& state, double delta_kinetic) {
  const MotionComponents parts = motion_components(model, adj);
  std::vector<Index> quanta, component;
  for (std::size_t i = 0; i < parts.of.size(); ++i)
    if (parts.of[i] != kNone) {
      quanta.push_back(static_cast<Index>(i));
      component.push_back(parts.of[i]);
    }
  return scale_internal_velocities(model, quanta, component, parts.anchored, state, delta_kinetic,
                                   [](std::span<double>) {})
      .lambda;
}

}  // namespace qbond
