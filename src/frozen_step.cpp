// The paper's hybrid step (Eq. 12) as one bond-centric pass in runs: see FrozenStep in
// implicit_system.hpp.
//
// The bonds are taken in runs of kBondRun (for_each_bond_run). A run's per-bond quantities are
// computed first in structure-of-arrays loops without branches, which the compiler vectorises
// across bonds (the ends' positions and velocities gathered), in functions compiled for several
// instruction sets (simd.hpp); then the run's ends are updated one bond at a time, in bond order,
// so that each quanta's sum keeps its order for any thread count.
#include <algorithm>
#include <cmath>

#include "implicit_system.hpp"
#include "simd.hpp"

namespace qbond {

namespace {

// A run's bonds, their parameters and their geometry, by bond k of the run. Every array the loops
// read or write is a member, so that the compiler sees that they do not overlap.
struct RunBonds {
  alignas(64) Index b[kBondRun], i[kBondRun], j[kBondRun];
  alignas(64) Index oi[kBondRun], oj[kBondRun];   // 3 i, 3 j: gathers vectorise on element offsets
  alignas(64) double k[kBondRun], L[kBondRun];    // strength, rest length
  alignas(64) double ca[kBondRun], cb[kBondRun];  // damping D as axial (ca) or isotropic (cb); the other 0
  alignas(64) double r[kBondRun], inv_r[kBondRun];
  alignas(64) double ux[kBondRun], uy[kBondRun], uz[kBondRun];  // unit vector from i to j
  alignas(64) double vi[kBondRun], vj[kBondRun];                // u·v_i, u·v_j
  alignas(64) double T[kBondRun], dT[kBondRun];                 // the law's tension and slope
};

// The run's bonds and parameters (kList: a list, else consecutive bonds, all loads contiguous);
// returns whether every bond's law is linear.
template <bool kList>
QBOND_VECTOR_INLINE bool load_bonds(const Model& model, const State& state, const BondRun& run, RunBonds& t) {
  const Index n = run.count;
  auto bond = [&](Index q) { return kList ? run.list[q] : run.first + q; };
  const Index* bond_i = model.bond_i.data();
  const Index* bond_j = model.bond_j.data();
  const double* stiffness = model.stiffness.data();
  const double* rest = state.rest.data();
  const double* damping = model.damping.data();
  const Law* law = model.law.data();
  const DampingModel* damping_model = model.damping_model.data();
  static_assert(static_cast<int>(Law::linear) == 0);
  unsigned nonlinear = 0;
  QBOND_SIMD for (Index q = 0; q < n; ++q) {
    const Index b = bond(q);
    t.b[q] = b;
    t.i[q] = bond_i[b];
    t.j[q] = bond_j[b];
    t.oi[q] = 3 * t.i[q];
    t.oj[q] = 3 * t.j[q];
    t.k[q] = stiffness[b];
    t.L[q] = rest[b];
    t.ca[q] = damping[b];
  }
  QBOND_SIMD_OR(nonlinear) for (Index q = 0; q < n; ++q) {
    const Index b = bond(q);
    const double axial = damping_model[b] == DampingModel::axial ? 1.0 : 0.0;
    const double D = t.ca[q];
    t.ca[q] = axial * D;  // exactly D and 0, or 0 and D
    t.cb[q] = D - t.ca[q];
    nonlinear |= static_cast<unsigned>(law[b]);
  }
  return nonlinear == 0;
}

// Fills t for the run: its bonds, parameters, unit vectors, u·v at both ends and the laws. A
// zero-length bond has no direction: its
// u, tension, slope and damping are 0 (the bond then does nothing, as in laws.hpp).
QBOND_VECTOR_INLINE void measure_run(const Model& model, const State& state, const BondRun& run,
                                     RunBonds& t) {
  const Index n = run.count;
  const double* x = state.x.data()->data();  // Vec3 arrays as doubles
  const double* v = state.v.data()->data();
  const bool all_linear =
      run.list ? load_bonds<true>(model, state, run, t) : load_bonds<false>(model, state, run, t);
  QBOND_SIMD for (Index q = 0; q < n; ++q) {
    const Index oi = t.oi[q], oj = t.oj[q];
    const double dx = x[oj] - x[oi], dy = x[oj + 1] - x[oi + 1], dz = x[oj + 2] - x[oi + 2];
    const double r = std::sqrt(dx * dx + dy * dy + dz * dz);
    // The division's operand is selected first so that the loop has no branch.
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
  QBOND_SIMD for (Index q = 0; q < n; ++q) {
    const bool ok = t.r[q] > 0;
    t.T[q] = ok ? t.T[q] : 0.0;
    t.dT[q] = ok ? t.dT[q] : 0.0;
    t.ca[q] = ok ? t.ca[q] : 0.0;
    t.cb[q] = ok ? t.cb[q] : 0.0;
  }
}

// The sum of a row's terms (as DiagonalRow::add takes them) over a stretch of consecutive bonds
// b, b + 1, ... with the same bond_i, added to that quanta's row once, when the stretch ends (it
// may go on into the part's next run). The stretches are the same for any partition, so the sums
// are too. One per part, on its thread.
struct BondStretch {
  static constexpr int N = 9;
  static constexpr Index kNone = ~Index{0};
  Index q = kNone;  // whose stretch
  Index next = 0;   // the bond that would go on with it
  double sum[N] = {};

  // Bond b, first end i (owned: whether this part updates i), adds d to i's row: starts or
  // continues the stretch, flush(q, sum) ending the previous one.
  template <class Flush>
  void add(Index b, Index i, bool owned, const double (&d)[N], Flush&& flush) {
    if (owned && q == i && next == b) {
      for (int e = 0; e < N; ++e) sum[e] += d[e];
    } else {
      end(flush);
      if (owned) {
        q = i;
        for (int e = 0; e < N; ++e) sum[e] = d[e];
      }
    }
    next = b + 1;
  }
  template <class Flush>
  void end(Flush&& flush) {
    if (q != kNone) flush(q, sum);
    q = kNone;
  }
};

// A run's terms, by bond k of the run: the six distinct entries of B_b = Ba u uᵀ + Bb I and the
// right-hand-side terms h T u + h C_b v_o on each end, kept as s_i u + hcb v_j on bond_i and
// s_j u + hcb v_i on bond_j (s = ±h T + h ca u·v_o, hcb = h cb).
struct FrozenTerms {
  alignas(64) double B[6][kBondRun];
  alignas(64) double si[kBondRun], sj[kBondRun], hcb[kBondRun];
};

// What a part keeps from run to run.
struct FrozenScratch {
  RunBonds bonds;
  FrozenTerms terms;
  BondStretch stretch;
};

// Fills the run's terms (linearise_bond's arithmetic, laid out for vectorising).
QBOND_VECTOR_CLONES void frozen_terms(const Model& model, const State& state, const BondRun& run, double h,
                                      RunBonds& g, FrozenTerms& t) {
  measure_run(model, state, run, g);
  const double h2 = h * h;
  QBOND_SIMD for (Index q = 0; q < run.count; ++q) {
    const double T = g.T[q], ca = g.ca[q], cb = g.cb[q];
    const double k_transverse = std::max(T * g.inv_r[q], 0.0), k_axial = std::max(g.dT[q], 0.0);
    const double Ba = h * ca + h2 * (k_axial - k_transverse), Bb = h * cb + h2 * k_transverse;
    const double ux = g.ux[q], uy = g.uy[q], uz = g.uz[q];
    const double aux = Ba * ux, auy = Ba * uy;
    t.B[0][q] = aux * ux + Bb;
    t.B[1][q] = auy * uy + Bb;
    t.B[2][q] = Ba * uz * uz + Bb;
    t.B[3][q] = aux * uy;
    t.B[4][q] = aux * uz;
    t.B[5][q] = auy * uz;
    t.si[q] = h * T + h * ca * g.vj[q];
    t.sj[q] = -h * T + h * ca * g.vi[q];
    t.hcb[q] = h * cb;
  }
}

// Adds the run's terms to both ends' rows, bond by bond: A_qq += B_b, rhs_q += s_q u + h cb v_o (q
// an end, o the other), bond_i's through the part's stretch. Kinematic rows are summed like the
// others and never solved.
QBOND_VECTOR_CLONES void frozen_scatter(const BondRun& run, const RunBonds& g, const FrozenTerms& t,
                                        const Vec3* v, DiagonalRow* rows, BondStretch& stretch) {
  BondStretch s = stretch;  // a local copy stays in registers
  auto flush = [&](Index q, const double(&sum)[9]) { rows[q].add(sum); };
  for (Index k = 0; k < run.count; ++k) {
    const Index i = g.i[k], j = g.j[k];
    double di[9], dj[9];  // the terms of bond_i's row and bond_j's (DiagonalRow::add)
    for (int e = 0; e < 6; ++e) di[e] = dj[e] = t.B[e][k];
    const Vec3 u(g.ux[k], g.uy[k], g.uz[k]);
    Vec3 bi = t.si[k] * u, bj = t.sj[k] * u;
    if (t.hcb[k] != 0) {
      bi += t.hcb[k] * v[j];
      bj += t.hcb[k] * v[i];
    }
    for (int e = 0; e < 3; ++e) {
      di[6 + e] = bi[e];
      dj[6 + e] = bj[e];
    }
    s.add(g.b[k], i, run.owns(i), di, flush);
    if (run.owns(j)) rows[j].add(dj);
  }
  if (run.last) s.end(flush);
  stretch = s;
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
  for_each_bond_run<FrozenScratch>(part, [&](const BondRun& run, FrozenScratch& s) {
    frozen_terms(model, state, run, h, s.bonds, s.terms);
    frozen_scatter(run, s.bonds, s.terms, state.v.data(), rows.data(), s.stretch);
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
