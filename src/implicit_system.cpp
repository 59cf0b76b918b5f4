#include "implicit_system.hpp"

#include <cmath>

namespace qbond {

void begin_implicit_step(const Model& model, const State& state, const std::vector<Vec3>& f_ext,
                         const StepContext& ctx, bool frozen, Projection& kin, ImplicitSystem& sys) {
  const std::size_t n = model.num_quanta(), nb = model.num_bonds();
  kin.resize(n);
  project_kinematic(model, state, ctx, kin);
  const double h = ctx.h;
  linearise_bonds(model, state, sys.bonds);
  sys.B.resize(nb);
  for (std::size_t b = 0; b < nb; ++b) sys.B[b] = h * sys.bonds.C[b] + (h * h) * sys.bonds.K[b];

  // Δx₀ and Δv_k, the motion already known before solving (see the header).
  auto dx0 = [&](Index i) -> Vec3 { return model.is_kinematic(i) ? kin.dx[i] : Vec3(h * state.v[i]); };
  auto dvk = [&](Index i) -> Vec3 { return model.is_kinematic(i) ? kin.dv[i] : Vec3::Zero(); };

  sys.diag.resize(n);
  sys.rhs.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    sys.diag[i] = model.mass[i] * Mat3::Identity();
    sys.rhs[i] = h * f_ext[i];
  }
  for (std::size_t b = 0; b < nb; ++b) {
    if (!state.alive[b]) continue;
    const Index i = model.bond_i[b], j = model.bond_j[b];
    sys.diag[i] += sys.B[b];
    sys.diag[j] += sys.B[b];
    const Vec3& f = sys.bonds.force[b];
    const Mat3& K = sys.bonds.K[b];
    const Mat3& C = sys.bonds.C[b];
    if (frozen) {
      // Neighbours at their start positions and at rest: only the quanta's own motion counts.
      sys.rhs[i] += h * f - h * (K * dx0(i));
      sys.rhs[j] += -h * f - h * (K * dx0(j));
    } else {
      // h f - h K (Δx₀_i - Δx₀_j) - h C (Δv_k,i - Δv_k,j), and the mirror for j.
      const Vec3 g = h * f - h * (K * (dx0(i) - dx0(j))) - h * (C * (dvk(i) - dvk(j)));
      sys.rhs[i] += g;
      sys.rhs[j] -= g;
    }
  }
  sys.diag_inv.resize(n);
  double norm2 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (model.is_kinematic(static_cast<Index>(i))) {
      sys.diag[i].setIdentity();
      sys.rhs[i].setZero();
    } else {
      norm2 += sys.rhs[i].squaredNorm();
    }
    // A_ii = m I + Σ B_b with B_b positive semi-definite: symmetric positive definite.
    sys.diag_inv[i] = sys.diag[i].inverse();
  }
  sys.rhs_norm = std::sqrt(norm2);
}

void apply_system(const Model& model, const ImplicitSystem& sys, const std::vector<Vec3>& y,
                  std::vector<Vec3>& out) {
  const std::size_t n = model.num_quanta(), nb = model.num_bonds();
  out.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    out[i] = model.is_kinematic(static_cast<Index>(i)) ? Vec3::Zero() : Vec3(sys.diag[i] * y[i]);
  for (std::size_t b = 0; b < nb; ++b) {
    const Index i = model.bond_i[b], j = model.bond_j[b];
    if (model.is_kinematic(i) || model.is_kinematic(j)) continue;  // kinematic unknowns eliminated
    out[i] -= sys.B[b] * y[j];
    out[j] -= sys.B[b] * y[i];
  }
}

double relative_residual(const Model& model, const ImplicitSystem& sys, const std::vector<Vec3>& y,
                         std::vector<Vec3>& scratch) {
  apply_system(model, sys, y, scratch);
  double r2 = 0;
  for (std::size_t i = 0; i < scratch.size(); ++i)
    if (!model.is_kinematic(static_cast<Index>(i))) r2 += (sys.rhs[i] - scratch[i]).squaredNorm();
  const double r = std::sqrt(r2);
  return sys.rhs_norm > 0 ? r / sys.rhs_norm : r;
}

}  // namespace qbond
