#include "forces.hpp"

#include "parallel.hpp"

namespace qbond {

void bond_forces(const Model& model, const State& state, const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                 int threads, std::vector<Vec3>& force) {
  force.resize(model.num_bonds());
  parallel_for(model.num_bonds(), threads, [&](std::size_t b) {
    if (!state.alive[b]) {
      force[b].setZero();
      return;
    }
    const Index i = model.bond_i[b], j = model.bond_j[b];
    force[b] = bond_force_on_i(model.law[b], model.damping_model[b], x[j] - x[i], v[j] - v[i], state.rest[b],
                               model.stiffness[b], model.damping[b], model.eps[b]);
  });
}

void gather_bond_forces(const Model& model, const Adjacency& adj, const std::vector<Vec3>& force, int threads,
                        std::vector<Vec3>& f) {
  parallel_for(model.num_quanta(), threads, [&](std::size_t q) {
    const auto i = static_cast<Index>(q);
    Vec3 sum = f[i];
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
      const Index b = adj.bond[e];
      if (model.bond_i[b] == i)
        sum += force[b];
      else
        sum -= force[b];
    }
    f[i] = sum;
  });
}

void accelerations(const Model& model, const State& state, const Adjacency& adj, const std::vector<Vec3>& x,
                   const std::vector<Vec3>& v, const std::vector<Vec3>& f_ext, int threads,
                   std::vector<Vec3>& scratch, std::vector<Vec3>& a) {
  bond_forces(model, state, x, v, threads, scratch);
  a = f_ext;
  gather_bond_forces(model, adj, scratch, threads, a);
  for (std::size_t i = 0; i < a.size(); ++i) a[i] *= model.inv_mass[i];
}

}  // namespace qbond
