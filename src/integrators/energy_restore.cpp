#include "integrators/energy_restore.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

namespace qbond {

namespace {
Index find(std::vector<Index>& parent, Index i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}
}  // namespace

double scale_internal_velocities(const Model& model, const Adjacency& adj, State& state, double delta_kinetic) {
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
  // Per component: mass, momentum, centre, angular momentum, inertia. Components are numbered in
  // the order of their roots (the smallest id), so sums run in a fixed order for any thread count.
  struct Part {
    double m = 0;
    Vec3 p = Vec3::Zero(), mx = Vec3::Zero(), l = Vec3::Zero();
    Mat3 inertia = Mat3::Zero();
    bool anchored = false;
    Vec3 v = Vec3::Zero(), c = Vec3::Zero(), w = Vec3::Zero();
  };
  std::vector<Part> part;
  std::vector<Index> comp(n, 0);  // the component of each free quanta
  for (std::size_t i = 0; i < n; ++i) {
    if (model.is_kinematic(static_cast<Index>(i))) continue;
    const Index r = find(parent, static_cast<Index>(i));
    if (r == i) {
      comp[i] = static_cast<Index>(part.size());
      part.emplace_back();
    } else {
      comp[i] = comp[r];  // r < i: numbered already
    }
    Part& q = part[comp[i]];
    q.m += model.mass[i];
    q.mx += model.mass[i] * state.x[i];
    q.p += model.mass[i] * state.v[i];
    q.anchored = q.anchored || anchored[i];
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (model.is_kinematic(static_cast<Index>(i))) continue;
    Part& q = part[comp[i]];
    if (q.anchored) continue;
    const Vec3 r = state.x[i] - q.mx / q.m;
    q.l += model.mass[i] * r.cross(state.v[i] - q.p / q.m);
    q.inertia += model.mass[i] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
  }
  for (Part& q : part) {
    if (q.anchored) continue;
    q.v = q.p / q.m;
    q.c = q.mx / q.m;
    // A collinear component has a singular inertia: its rotation about the line carries no energy.
    q.w = q.inertia.completeOrthogonalDecomposition().solve(q.l);
  }
  auto internal = [&](std::size_t i) -> Vec3 {
    const Part& q = part[comp[i]];
    return q.anchored ? state.v[i] : Vec3(state.v[i] - q.v - q.w.cross(state.x[i] - q.c));
  };
  double k_internal = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (!model.is_kinematic(static_cast<Index>(i))) k_internal += 0.5 * model.mass[i] * internal(i).squaredNorm();
  if (!(k_internal > 0)) return 1;
  const double lambda = std::sqrt(std::clamp(1 + delta_kinetic / k_internal, 0.0, 100.0));
  for (std::size_t i = 0; i < n; ++i)
    if (!model.is_kinematic(static_cast<Index>(i))) state.v[i] += (lambda - 1) * internal(i);
  return lambda;
}

}  // namespace qbond
