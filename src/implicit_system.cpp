#include "implicit_system.hpp"

#include <cmath>

#include "parallel.hpp"

namespace qbond {

void begin_implicit_step(const Model& model, const State& state, const Adjacency& adj,
                         const std::vector<Vec3>& f_ext, const StepContext& ctx, bool frozen, int threads,
                         Projection& kin, ImplicitSystem& sys) {
  const std::size_t n = model.num_quanta(), nb = model.num_bonds();
  kin.resize(n);
  project_kinematic(model, state, ctx, kin);
  const double h = ctx.h;
  linearise_bonds(model, state, sys.bonds, threads);

  // Δx₀ and Δv_k, the motion already known before solving (see the header).
  auto dx0 = [&](Index i) -> Vec3 { return model.is_kinematic(i) ? kin.dx[i] : Vec3(h * state.v[i]); };
  auto dvk = [&](Index i) -> Vec3 { return model.is_kinematic(i) ? kin.dv[i] : Vec3::Zero(); };

  // Per bond: B_b and its right-hand-side term g_b (on i; j gets -g_b). With `frozen` the
  // neighbours sit at their start positions and at rest, so g_b = h f and each end adds its own
  // -h K Δx₀ when gathering.
  sys.B.resize(nb);
  sys.g.resize(nb);
  parallel_for(nb, threads, [&](std::size_t b) {
    const Mat3& K = sys.bonds.K[b];
    const Mat3& C = sys.bonds.C[b];
    sys.B[b] = h * C + (h * h) * K;
    const Index i = model.bond_i[b], j = model.bond_j[b];
    sys.g[b] = frozen ? Vec3(h * sys.bonds.force[b])
                      : Vec3(h * sys.bonds.force[b] - h * (K * (dx0(i) - dx0(j))) - h * (C * (dvk(i) - dvk(j))));
  });
  // Per quanta, gathered over its bonds in bond order: A_ii = m I + Σ B_b, b_i = h f_ext + Σ ±g_b.
  sys.diag.resize(n);
  sys.diag_inv.resize(n);
  sys.rhs.resize(n);
  parallel_for(n, threads, [&](std::size_t q) {
    const auto i = static_cast<Index>(q);
    if (model.is_kinematic(i)) {
      sys.diag[i].setIdentity();
      sys.diag_inv[i].setIdentity();
      sys.rhs[i].setZero();
      return;
    }
    Mat3 d = model.mass[i] * Mat3::Identity();
    Vec3 r = h * f_ext[i];
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
      const Index b = adj.bond[e];
      d += sys.B[b];
      const bool first = model.bond_i[b] == i;
      if (frozen)
        r += (first ? sys.g[b] : Vec3(-sys.g[b])) - h * (sys.bonds.K[b] * dx0(i));
      else if (first)
        r += sys.g[b];
      else
        r -= sys.g[b];
    }
    sys.diag[i] = d;
    sys.rhs[i] = r;
    // A_ii = m I + Σ B_b with B_b positive semi-definite: symmetric positive definite.
    sys.diag_inv[i] = d.inverse();
  });
  sys.rhs_norm = std::sqrt(deterministic_sum(n, threads, [&](std::size_t i) { return sys.rhs[i].squaredNorm(); }));
}

void apply_system(const Model& model, const Adjacency& adj, const ImplicitSystem& sys, const std::vector<Vec3>& y,
                  int threads, std::vector<Vec3>& out) {
  out.resize(model.num_quanta());
  parallel_for(model.num_quanta(), threads, [&](std::size_t q) {
    const auto i = static_cast<Index>(q);
    if (model.is_kinematic(i)) {
      out[i].setZero();
      return;
    }
    Vec3 a = sys.diag[i] * y[i];
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
      const Index j = adj.other[e];
      if (!model.is_kinematic(j)) a -= sys.B[adj.bond[e]] * y[j];  // kinematic unknowns eliminated
    }
    out[i] = a;
  });
}

}  // namespace qbond
