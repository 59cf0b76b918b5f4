// The paper's hybrid step (Eq. 12) as one bond-centric pass in runs (bond_run.hpp): see FrozenStep
// in implicit_system.hpp.
#include <algorithm>

#include "bond_run.hpp"
#include "implicit_system.hpp"

namespace qbond {

namespace {

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
  BondStretch<9> stretch;  // as DiagonalRow::add takes a row's terms
};

// Fills the run's terms (linearise_bond's arithmetic, laid out for vectorising).
QBOND_VECTOR_CLONES void frozen_terms(const Model& model, const State& state, const BondRun& run, double h,
                                      RunBonds& g, FrozenTerms& t) {
  measure_run(model, state, state.x.data()->data(), state.v.data()->data(), run, g);
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
                                        const Vec3* v, DiagonalRow* rows, BondStretch<9>& stretch) {
  BondStretch<9> s = stretch;  // a local copy stays in registers
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
