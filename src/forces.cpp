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

void linearise_bonds(const Model& model, const State& state, BondLinearisation& out, int threads) {
  const std::size_t nb = model.num_bonds();
  out.force.resize(nb);
  out.K.resize(nb);
  out.C.resize(nb);
  parallel_for(nb, threads, [&](std::size_t b) {
    out.force[b].setZero();
    out.K[b].setZero();
    out.C[b].setZero();
    if (!state.alive[b]) return;
    const Index i = model.bond_i[b], j = model.bond_j[b];
    const Vec3 d = state.x[j] - state.x[i];
    const double r = d.norm();
    if (!(r > 0)) return;  // a zero-length bond has no direction: no force, no coupling
    const Vec3 u = d / r;
    const LawValue lv = model.law_at(b, r, state.rest[b]);
    const Vec3 w = state.v[j] - state.v[i];
    out.force[b] = lv.T * u + (model.damping_model[b] == DampingModel::axial
                                   ? Vec3(model.damping[b] * w.dot(u) * u)
                                   : Vec3(model.damping[b] * w));
    out.K[b] = stiffness_block(lv.T, lv.dT, r, u, /*clamp_for_solver=*/true);
    out.C[b] = damping_block(model.damping_model[b], model.damping[b], u);
  });
}

}  // namespace qbond
