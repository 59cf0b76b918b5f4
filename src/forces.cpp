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

void add_bond_forces(const Model& model, const State& state, const BondPartition& part, const std::vector<Vec3>& x,
                     const std::vector<Vec3>& v, std::vector<Vec3>& f) {
  // Raw pointers held in the loop: through the containers the compiler reloads them every bond.
  const Index* bi = model.bond_i.data();
  const Index* bj = model.bond_j.data();
  const Law* law = model.law.data();
  const DampingModel* dm = model.damping_model.data();
  const double* k = model.stiffness.data();
  const double* D = model.damping.data();
  const double* eps = model.eps.data();
  const double* L = state.rest.data();
  const Vec3* xp = x.data();
  const Vec3* vp = v.data();
  Vec3* fp = f.data();
  for_each_bond(part, model, [=](Index b, bool own_i, bool own_j) {
    const Index i = bi[b], j = bj[b];
    const Vec3 fb = bond_force_on_i(law[b], dm[b], xp[j] - xp[i], vp[j] - vp[i], L[b], k[b], D[b], eps[b]);
    if (own_i) fp[i] += fb;
    if (own_j) fp[j] -= fb;
  });
}

void accelerations(const Model& model, const State& state, const BondPartition& part, const std::vector<Vec3>& x,
                   const std::vector<Vec3>& v, const std::vector<Vec3>& f_ext, int threads, std::vector<Vec3>& a) {
  a.resize(model.num_quanta());
  parallel_for(a.size(), threads, [&](std::size_t i) { a[i] = f_ext[i]; });
  add_bond_forces(model, state, part, x, v, a);
  parallel_for(a.size(), threads, [&](std::size_t i) { a[i] *= model.inv_mass[i]; });
}

}  // namespace qbond
