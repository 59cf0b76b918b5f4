#include "forces.hpp"

namespace qbond {

void add_bond_forces(const Model& model, const State& state, const std::vector<Vec3>& x,
                     const std::vector<Vec3>& v, std::vector<Vec3>& f) {
  const std::size_t nb = model.num_bonds();
  for (std::size_t b = 0; b < nb; ++b) {
    if (!state.alive[b]) continue;
    const Index i = model.bond_i[b], j = model.bond_j[b];
    const Vec3 fi = bond_force_on_i(model.law[b], model.damping_model[b], x[j] - x[i], v[j] - v[i],
                                    state.rest[b], model.stiffness[b], model.damping[b], model.eps[b]);
    f[i] += fi;
    f[j] -= fi;
  }
}

void accelerations(const Model& model, const State& state, const std::vector<Vec3>& x,
                   const std::vector<Vec3>& v, const std::vector<Vec3>& f_ext,
                   std::vector<Vec3>& a) {
  a = f_ext;
  add_bond_forces(model, state, x, v, a);
  for (std::size_t i = 0; i < a.size(); ++i) a[i] *= model.inv_mass[i];
}

void linearise_bonds(const Model& model, const State& state, BondLinearisation& out) {
  const std::size_t nb = model.num_bonds();
  out.force.resize(nb);
  out.K.resize(nb);
  out.C.resize(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    out.force[b].setZero();
    out.K[b].setZero();
    out.C[b].setZero();
    if (!state.alive[b]) continue;
    const Index i = model.bond_i[b], j = model.bond_j[b];
    const Vec3 d = state.x[j] - state.x[i];
    const double r = d.norm();
    if (!(r > 0)) continue;  // a zero-length bond has no direction: no force, no coupling
    const Vec3 u = d / r;
    const LawValue lv = evaluate_law(model.law[b], r, state.rest[b], model.stiffness[b], model.eps[b]);
    const Vec3 w = state.v[j] - state.v[i];
    out.force[b] = lv.T * u + (model.damping_model[b] == DampingModel::axial
                                   ? Vec3(model.damping[b] * w.dot(u) * u)
                                   : Vec3(model.damping[b] * w));
    out.K[b] = stiffness_block(lv.T, lv.dT, r, u, /*clamp_for_solver=*/true);
    out.C[b] = damping_block(model.damping_model[b], model.damping[b], u);
  }
}

}  // namespace qbond
