// The paper's hybrid step (Eq. 12) as one bond-centric pass: see FrozenStep in implicit_system.hpp.
//
// The pass takes the bonds in runs of kBondRun. A run's per-bond terms (direction, law, the block
// B_b and the right-hand-side scalars) are computed first, in structure-of-arrays loops without
// branches that the compiler vectorises across bonds (gathering the ends' positions and
// velocities); then the run's ends are updated one bond at a time, in bond order, which keeps the
// sums of each quanta in the same order for any thread count.
#include <algorithm>
#include <cmath>

#include "implicit_system.hpp"
#include "simd.hpp"

namespace qbond {

namespace {

// A run's per-bond terms, by bond k of the run: the unit vector u, the six distinct entries of
// B_b = Ba u uᵀ + Bb I, and the right-hand-side terms h T u + h C_b v_o on each end, kept as
// s_i u + hcb v_j on bond_i and s_j u + hcb v_i on bond_j (s = ±h T + h ca u·v_o, hcb = h cb).
// Every array the loops read or write is a member, so that the compiler sees they do not overlap.
struct FrozenTerms {
  alignas(64) Index i[kBondRun], j[kBondRun];
  alignas(64) double ux[kBondRun], uy[kBondRun], uz[kBondRun];
  alignas(64) double B[6][kBondRun];
  alignas(64) double si[kBondRun], sj[kBondRun], hcb[kBondRun];
  // scratch between the loops
  alignas(64) Index b[kBondRun], oi[kBondRun], oj[kBondRun];  // oi, oj: 3 i, 3 j (gathers' offsets)
  alignas(64) double k[kBondRun], L[kBondRun], D[kBondRun], axial[kBondRun];  // axial: 1 or 0
  alignas(64) double r[kBondRun], inv_r[kBondRun], T[kBondRun], dT[kBondRun], vi[kBondRun], vj[kBondRun];
};

// The run's bonds and their parameters into t; kList: the run is a list, else consecutive bonds
// (then every load is contiguous). Returns whether every bond's law is linear.
template <bool kList>
inline bool load_run(const Model& model, const State& state, const BondRun& run, FrozenTerms& t) {
  const Index n = run.count;
  auto bond = [&](Index q) { return kList ? run.list[q] : run.first + q; };
  const double* stiffness = model.stiffness.data();
  const double* rest = state.rest.data();
  const double* damping = model.damping.data();
  const Law* law = model.law.data();
  const DampingModel* damping_model = model.damping_model.data();
  unsigned nonlinear = 0;
  static_assert(static_cast<int>(Law::linear) == 0);
  QBOND_SIMD for (Index q = 0; q < n; ++q) {
    const Index b = bond(q);
    t.b[q] = b;
    t.k[q] = stiffness[b];
    t.L[q] = rest[b];
    t.D[q] = damping[b];
  }
  QBOND_SIMD_OR(nonlinear) for (Index q = 0; q < n; ++q) {
    const Index b = bond(q);
    t.axial[q] = damping_model[b] == DampingModel::axial ? 1.0 : 0.0;
    nonlinear |= static_cast<unsigned>(law[b]);
  }
  return nonlinear == 0;
}

// Fills t for the run's bonds (linearise_bond's arithmetic, laid out for vectorising).
QBOND_VECTOR_CLONES void frozen_terms(const Model& model, const State& state, const BondRun& run, double h,
                                      FrozenTerms& t) {
  const Index n = run.count;
  const Index* bond_i = model.bond_i.data();
  const Index* bond_j = model.bond_j.data();
  const double* x = state.x.data()->data();
  const double* v = state.v.data()->data();
  const bool all_linear =
      run.list ? load_run<true>(model, state, run, t) : load_run<false>(model, state, run, t);
  QBOND_SIMD for (Index q = 0; q < n; ++q) {
    t.i[q] = bond_i[t.b[q]];
    t.j[q] = bond_j[t.b[q]];
    t.oi[q] = 3 * t.i[q];  // gathers vectorise on element offsets, not on 3 × index
    t.oj[q] = 3 * t.j[q];
  }
  QBOND_SIMD for (Index q = 0; q < n; ++q) {
    const Index oi = t.oi[q], oj = t.oj[q];
    const double dx = x[oj] - x[oi], dy = x[oj + 1] - x[oi + 1], dz = x[oj + 2] - x[oi + 2];
    const double r = std::sqrt(dx * dx + dy * dy + dz * dz);
    // A zero-length bond has no direction: u = 0 and, below, no tension, stiffness or damping.
    // (The division's operand is selected first so that the loop has no branch.)
    const bool ok = r > 0;
    const double inv_r = ok ? 1.0 / (ok ? r : 1.0) : 0.0;
    const double ux = inv_r * dx, uy = inv_r * dy, uz = inv_r * dz;
    t.r[q] = r;
    t.inv_r[q] = inv_r;
    t.ux[q] = ux;
    t.uy[q] = uy;
    t.uz[q] = uz;
    t.vi[q] = ux * v[oi] + uy * v[oi + 1] + uz * v[oi + 2];
    t.vj[q] = ux * v[oj] + uy * v[oj + 1] + uz * v[oj + 2];
  }
  if (all_linear) {
    QBOND_SIMD for (Index q = 0; q < n; ++q) {
      t.T[q] = t.k[q] * (t.r[q] - t.L[q]);
      t.dT[q] = t.k[q];
    }
  } else {
    for (Index q = 0; q < n; ++q) {
      const LawValue lv = model.law_at(t.b[q], t.r[q], t.L[q]);
      t.T[q] = lv.T;
      t.dT[q] = lv.dT;
    }
  }
  const double h2 = h * h;
  QBOND_SIMD for (Index q = 0; q < n; ++q) {
    const bool ok = t.r[q] > 0;
    const double T = ok ? t.T[q] : 0.0, dT = ok ? t.dT[q] : 0.0, D = ok ? t.D[q] : 0.0;
    const double k_transverse = std::max(T * t.inv_r[q], 0.0), k_axial = std::max(dT, 0.0);
    const double ca = t.axial[q] * D, cb = D - ca;  // exactly D and 0, or 0 and D
    const double Ba = h * ca + h2 * (k_axial - k_transverse), Bb = h * cb + h2 * k_transverse;
    const double ux = t.ux[q], uy = t.uy[q], uz = t.uz[q];
    const double aux = Ba * ux, auy = Ba * uy;
    t.B[0][q] = aux * ux + Bb;
    t.B[1][q] = auy * uy + Bb;
    t.B[2][q] = Ba * uz * uz + Bb;
    t.B[3][q] = aux * uy;
    t.B[4][q] = aux * uz;
    t.B[5][q] = auy * uz;
    t.si[q] = h * T + h * ca * t.vj[q];
    t.sj[q] = -h * T + h * ca * t.vi[q];
    t.hcb[q] = h * cb;
  }
}

// Adds the run's terms to both ends' rows, bond by bond: A_qq += B_b, rhs_q += s_q u + h cb v_o (q
// an end, o the other). A stretch of consecutive bonds b, b + 1, ... with the same bond_i is summed
// in `pending` and added to that row once, when the stretch ends (it may go on into the part's
// next run): the stretches are the same for any partition, so the sums are too. Kinematic rows are
// summed like the others and never solved.
QBOND_VECTOR_CLONES void frozen_scatter(const BondRun& run, const FrozenTerms& t, const Vec3* v,
                                        DiagonalRow* rows, FrozenStep::Pending& pending) {
  FrozenStep::Pending p = pending;  // a local copy stays in registers
  auto flush = [&] {
    if (p.q != FrozenStep::kNoQuanta) rows[p.q].add(p.sum);
    p.q = FrozenStep::kNoQuanta;
  };
  for (Index k = 0; k < run.count; ++k) {
    const Index b = t.b[k], i = t.i[k], j = t.j[k];
    double di[9], dj[9];  // the terms of bond_i's row and bond_j's (DiagonalRow::add)
    for (int e = 0; e < 6; ++e) di[e] = dj[e] = t.B[e][k];
    const Vec3 u(t.ux[k], t.uy[k], t.uz[k]);
    Vec3 bi = t.si[k] * u, bj = t.sj[k] * u;
    if (t.hcb[k] != 0) {
      bi += t.hcb[k] * v[j];
      bj += t.hcb[k] * v[i];
    }
    for (int e = 0; e < 3; ++e) {
      di[6 + e] = bi[e];
      dj[6 + e] = bj[e];
    }
    if (run.owns(i)) {
      if (p.q == i && p.next == b) {
        for (int e = 0; e < 9; ++e) p.sum[e] += di[e];
      } else {
        flush();
        p.q = i;
        for (int e = 0; e < 9; ++e) p.sum[e] = di[e];
      }
    } else {
      flush();
    }
    p.next = b + 1;
    if (run.owns(j)) rows[j].add(dj);
  }
  if (run.last) flush();
  pending = p;
}

}  // namespace

void FrozenStep::project(const Model& model, const State& state, const Adjacency& adj,
                         const std::vector<Vec3>& f_ext, const StepContext& ctx, int threads,
                         Projection& out) {
  const std::size_t n = model.num_quanta();
  const double h = ctx.h;
  out.resize(n);
  project_kinematic(model, state, ctx, out);
  part.update(model, adj, threads);
  rows.resize(n);
  parallel_for(n, threads, [&](std::size_t i) {
    rows[i].start(model.mass[i], model.mass[i] * state.v[i] + h * f_ext[i]);
  });
  pending.assign(static_cast<std::size_t>(part.parts()), Pending{});
  for_each_bond_run(part, [&](const BondRun& run) {
    FrozenTerms t;
    frozen_terms(model, state, run, h, t);
    frozen_scatter(run, t, state.v.data(), rows.data(), pending[static_cast<std::size_t>(run.part)]);
  });
  parallel_for(n, threads, [&](std::size_t q) {
    const auto i = static_cast<Index>(q);
    if (model.is_kinematic(i)) return;
    // m I + Σ B_b with B_b positive semi-definite: symmetric positive definite.
    const Vec3 v1 = rows[i].solve();
    out.dv[i] = v1 - state.v[i];
    out.dx[i] = h * v1;
  });
}

}  // namespace qbond
