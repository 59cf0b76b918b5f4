// The paper's hybrid step (Eq. 12) as one bond-centric pass in runs: see FrozenStep in
// backward_euler.hpp.
//
// The bonds are taken in runs of at most kBondRun (for_each_bond_run). An affine run (bond
// first + k joins i0 + k and j0 + k: a lattice's bonds grouped by offset) whose bonds are linear
// with one damping model is measured and formed in one vector loop reading the ends' data as
// contiguous vectors, and its terms are added to the rows (kept as structure of arrays) by
// that loop when its ends are far enough apart, else by vector loops after it. Other runs
// compute their per-bond terms in vector loops with the ends' data gathered, then update the
// rows one bond at a time. Either way each row receives its bonds in bond order, so its sum is
// the same for any thread count. A part's rows are started and solved, and its positions and
// velocities copied for the affine runs, in the wake of its bond pass, while they are in cache.
// The vector functions are compiled for several instruction sets (simd.hpp).
#include <algorithm>
#include <atomic>
#include <cmath>

#include "integrators/affine_run_terms.hpp"
#include "integrators/backward_euler.hpp"
#include "integrators/integrator_common.hpp"
#include "core/simd.hpp"

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

// The run's bonds, their ends and their parameters (kList: a list, else consecutive bonds, all
// loads contiguous); returns whether every bond's law is linear.
template <bool kList>
QBOND_VECTOR_INLINE bool load_bonds(const State& state, const BondRun& run, RunBonds& t) {
  const Index n = run.count;
  // Consecutive bonds index arrays advanced to the run's first bond: first + q, a 32-bit sum that
  // the compiler must assume may wrap, would make every load a gather.
  const std::size_t base = kList ? 0 : run.first;
  auto bond = [&](Index q) { return kList ? run.list[q] : q; };
  const Index* bond_i = state.bonds.i.data() + base;
  const Index* bond_j = state.bonds.j.data() + base;
  const double* stiffness = state.bonds.strength.data() + base;
  const double* rest = state.bonds.rest.data() + base;
  const double* damping = state.bonds.damping.data() + base;
  const Law* law = state.bonds.law.data() + base;
  const DampingModel* damping_model = state.bonds.damping_model.data() + base;
  static_assert(static_cast<int>(Law::linear) == 0);
  unsigned nonlinear = 0;
  QBOND_SIMD for (Index q = 0; q < n; ++q) {
    const Index b = bond(q);
    t.b[q] = run.bond(q);
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

// The step's per-quanta arrays, as structure of arrays (FrozenStep::arrays): the rows A_ii (six
// distinct entries: xx, yy, zz, xy, xz, yz) and b_i (x, y, z), and copies of the positions and
// velocities from which affine runs load contiguous vectors.
struct StepArrays {
  double* row[9];
  double* x[3];
  double* v[3];
  QBOND_VECTOR_INLINE void add(Index q, const double (&d)[9]) const {
    for (int k = 0; k < 9; ++k) row[k][q] += d[k];
  }
};

// A bond's r, 1/r (length), u, u·v_i and u·v_j from d = x_j − x_i and its ends' velocities
// (oriented: with r and 1/r given, AffineLengths). A zero-length bond has no direction: u = 0
// (its tension, slope and damping are then masked to 0).
struct Geometry {
  double r, inv_r, u[3], u_vi, u_vj;
};
QBOND_VECTOR_INLINE Geometry oriented(double r, double inv_r, double dx, double dy, double dz, double vix, double viy,
                                      double viz, double vjx, double vjy, double vjz) {
  Geometry g;
  g.r = r;
  g.inv_r = inv_r;
  g.u[0] = g.inv_r * dx;
  g.u[1] = g.inv_r * dy;
  g.u[2] = g.inv_r * dz;
  g.u_vi = g.u[0] * vix + g.u[1] * viy + g.u[2] * viz;
  g.u_vj = g.u[0] * vjx + g.u[1] * vjy + g.u[2] * vjz;
  return g;
}
QBOND_VECTOR_INLINE Geometry geometry(double dx, double dy, double dz, double vix, double viy, double viz, double vjx,
                                      double vjy, double vjz) {
  const Length l = length(dx, dy, dz);
  return oriented(l.r, l.inv_r, dx, dy, dz, vix, viy, viz, vjx, vjy, vjz);
}
QBOND_VECTOR_INLINE void set_geometry(RunBonds& t, std::size_t q, const Geometry& g) {
  t.r[q] = g.r;
  t.inv_r[q] = g.inv_r;
  t.ux[q] = g.u[0];
  t.uy[q] = g.u[1];
  t.uz[q] = g.u[2];
  t.vi[q] = g.u_vi;
  t.vj[q] = g.u_vj;
}

// Fills t for the run: its bonds, parameters, unit vectors, u·v at both ends (gathered) and laws.
// A zero-length bond's tension, slope and damping are 0 (the bond then does nothing, as in
// laws.hpp).
QBOND_VECTOR_INLINE void measure_run(const Model& model, const State& state, const BondRun& run, RunBonds& t) {
  const Index n = run.count;
  const bool all_linear = run.list ? load_bonds<true>(state, run, t) : load_bonds<false>(state, run, t);
  const double* x = state.x.data()->data();  // Vec3 arrays as doubles
  const double* v = state.v.data()->data();
  QBOND_SIMD for (std::size_t q = 0; q < n; ++q) {
    const Index oi = t.oi[q], oj = t.oj[q];
    set_geometry(t, q,
                 geometry(x[oj] - x[oi], x[oj + 1] - x[oi + 1], x[oj + 2] - x[oi + 2], v[oi], v[oi + 1], v[oi + 2],
                          v[oj], v[oj + 1], v[oj + 2]));
  }
  if (all_linear) {
    QBOND_SIMD for (std::size_t q = 0; q < n; ++q) {
      t.T[q] = t.k[q] * (t.r[q] - t.L[q]);
      t.dT[q] = t.k[q];
    }
  } else {
    for (std::size_t q = 0; q < n; ++q) {
      const LawValue lv = state.bonds.law_at(model.shapes, run.bond(static_cast<Index>(q)), t.r[q], t.L[q]);
      t.T[q] = lv.T;
      t.dT[q] = lv.dT;
    }
  }
  QBOND_SIMD for (std::size_t q = 0; q < n; ++q) {
    const bool ok = t.r[q] > 0;
    t.T[q] = ok ? t.T[q] : 0.0;
    t.dT[q] = ok ? t.dT[q] : 0.0;
    t.ca[q] = ok ? t.ca[q] : 0.0;
    t.cb[q] = ok ? t.cb[q] : 0.0;
  }
}

// The sum of a row's terms (as StepArrays::add takes them) over a stretch of consecutive bonds
// b, b + 1, ... with the same bond_i, added to that quanta's row once, when the stretch ends (it
// may go on into the part's next run). The stretches are the same for any partition, so the sums
// are too. One per part, on its thread.
struct BondStretch {
  static constexpr int N = 9;
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
// s_j u + hcb v_i on bond_j (s = ±h T + h ca u·v_o, hcb = h cb) on the per-bond path, or, for
// an affine run, those two terms themselves, ri and rj.
struct FrozenTerms {
  alignas(64) double B[6][kBondRun];
  alignas(64) double si[kBondRun], sj[kBondRun], hcb[kBondRun];
  alignas(64) double ri[3][kBondRun], rj[3][kBondRun];
  alignas(64) double r[kBondRun], inv_r[kBondRun];  // an affine run's lengths (AffineLengths)
};

// What a part keeps from run to run.
struct FrozenScratch {
  RunBonds bonds;
  FrozenTerms terms;
  BondStretch stretch;
  int part = -1;                  // which part, from its first run on
  Index started = 0, solved = 0;  // the part's rows from its first are started up to here, solved up to here
};

// A bond's block B_b = Ba u uᵀ + Bb I (its six distinct entries) and its right-hand-side
// coefficients s_i = h T + h ca u·v_j, s_j = −h T + h ca u·v_i and h cb (linearise_bond's
// arithmetic), from its tension T, slope dT, damping (ca axial, cb isotropic) and geometry.
struct BondBlock {
  double B[6], si, sj, hcb;
};
QBOND_VECTOR_INLINE BondBlock bond_block(double h, double T, double dT, double ca, double cb, const Geometry& g) {
  const double h2 = h * h;
  const StiffnessCoefficients k = clamped_stiffness(dT, T * g.inv_r);
  const double Ba = h * ca + h2 * k.ka(), Bb = h * cb + h2 * k.kb();
  const double ux = g.u[0], uy = g.u[1], uz = g.u[2];
  const double aux = Ba * ux, auy = Ba * uy;
  return {{aux * ux + Bb, auy * uy + Bb, Ba * uz * uz + Bb, aux * uy, aux * uz, auy * uz},
          h * T + h * ca * g.u_vj,
          -h * T + h * ca * g.u_vi,
          h * cb};
}

// The terms of bond q of an affine run of linear bonds with one damping model (kAxial: axial) on
// bond_i's row (ti) and bond_j's (tj), as StepArrays::add takes them: its block, and each end's
// right-hand side s u + h cb v_other; the bonds' lengths r and 1/r already in r, inv_r.
template <bool kAxial>
struct LinearAffineBonds {
  RunParameters p;
  const double *x[3], *v[3], *r, *inv_r;
  std::size_t i0, j0;
  double h;

  LinearAffineBonds(const State& state, const StepArrays& a, const BondRun& run, double h,
                    const FrozenTerms& t)
      : p(state, run),
        x{a.x[0], a.x[1], a.x[2]},
        v{a.v[0], a.v[1], a.v[2]},
        r(t.r),
        inv_r(t.inv_r),
        i0(run.i0),
        j0(run.j0),
        h(h) {}
  QBOND_VECTOR_INLINE void operator()(std::size_t q, double (&ti)[9], double (&tj)[9]) const {
    const double kq = p.k[q], Lq = p.L[q], Dq = p.D[q];  // loaded unconditionally: selects, not branches
    const std::size_t i = i0 + q, j = j0 + q;
    const double wi[3] = {v[0][i], v[1][i], v[2][i]}, wj[3] = {v[0][j], v[1][j], v[2][j]};
    const Geometry g = oriented(r[q], inv_r[q], x[0][j] - x[0][i], x[1][j] - x[1][i], x[2][j] - x[2][i], wi[0], wi[1],
                                wi[2], wj[0], wj[1], wj[2]);
    const bool ok = g.r > 0;  // a zero-length bond does nothing (laws.hpp)
    const double T = ok ? kq * (g.r - Lq) : 0.0, dT = ok ? kq : 0.0, D_ok = ok ? Dq : 0.0;
    const BondBlock k = bond_block(h, T, dT, kAxial ? D_ok : 0.0, kAxial ? 0.0 : D_ok, g);
    // Unrolled first: GCC otherwise leaves these loops in the bond loop when vectorising for
    // AVX2, and with them the whole bond loop scalar. Axial: h cb is 0, and its term is left out
    // (0 · v is not 0 for every v, so the compiler cannot drop it).
    QBOND_UNROLL(6) for (int e = 0; e < 6; ++e) ti[e] = tj[e] = k.B[e];
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) {
      ti[6 + c] = kAxial ? k.si * g.u[c] : k.si * g.u[c] + k.hcb * wj[c];
      tj[6 + c] = kAxial ? k.sj * g.u[c] : k.sj * g.u[c] + k.hcb * wi[c];
    }
  }
};

// An affine run of linear bonds with one damping model (kAxial: axial), measured, formed and added
// to the rows its part owns (add_affine_terms; bond_i's and bond_j's terms share the blocks).
template <bool kAxial>
QBOND_VECTOR_INLINE void linear_affine_run(const State& state, const StepArrays& a, const BondRun& run, double h,
                                           FrozenTerms& t) {
  const LinearAffineBonds<kAxial> bonds(state, a, run, h, t);
  add_affine_terms(run, a.row, bonds,
                   {t.B[0], t.B[1], t.B[2], t.B[3], t.B[4], t.B[5], t.ri[0], t.ri[1], t.ri[2]},
                   {t.B[0], t.B[1], t.B[2], t.B[3], t.B[4], t.B[5], t.rj[0], t.rj[1], t.rj[2]},
                   AffineLengths(run, a.x, t.r, t.inv_r));
}

// An affine run that uniform_linear accepts (axial: its damping model is axial), after the part's
// stretch (its bonds have distinct bond_i).
QBOND_VECTOR_CLONES void affine_run(const State& state, const StepArrays& a, const BondRun& run, double h, bool axial,
                                    FrozenTerms& t, BondStretch& stretch) {
  prefetch_parameters(state, run);
  stretch.end([&](Index q, const double(&sum)[9]) { a.add(q, sum); });
  if (axial)
    linear_affine_run<true>(state, a, run, h, t);
  else
    linear_affine_run<false>(state, a, run, h, t);
}

// The terms of any other run (the per-bond path): measured (measure_run), then formed.
QBOND_VECTOR_CLONES void frozen_terms(const Model& model, const State& state, const BondRun& run, double h,
                                      RunBonds& g, FrozenTerms& t) {
  measure_run(model, state, run, g);
  QBOND_SIMD for (std::size_t q = 0; q < run.count; ++q) {
    const Geometry geo{g.r[q], g.inv_r[q], {g.ux[q], g.uy[q], g.uz[q]}, g.vi[q], g.vj[q]};
    const BondBlock k = bond_block(h, g.T[q], g.dT[q], g.ca[q], g.cb[q], geo);
    for (int e = 0; e < 6; ++e) t.B[e][q] = k.B[e];
    t.si[q] = k.si;
    t.sj[q] = k.sj;
    t.hcb[q] = k.hcb;
  }
}

// Adds the run's terms to both ends' rows, bond by bond: A_qq += B_b, rhs_q += s_q u + h cb v_o (q
// an end, o the other), bond_i's through the part's stretch. Kinematic rows are summed like the
// others and never solved.
QBOND_VECTOR_CLONES void frozen_scatter(const BondRun& run, const RunBonds& g, const FrozenTerms& t,
                                        const Vec3* v, const StepArrays& rows, BondStretch& stretch) {
  BondStretch s = stretch;  // a local copy stays in registers
  auto flush = [&](Index q, const double(&sum)[9]) { rows.add(q, sum); };
  for (Index k = 0; k < run.count; ++k) {
    const Index i = g.i[k], j = g.j[k];
    double di[9], dj[9];  // the terms of bond_i's row and bond_j's (StepArrays::add)
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
    if (run.owns(j)) rows.add(j, dj);
  }
  if (run.last) s.end(flush);
  stretch = s;
}

// The structure-of-arrays copies of x and v the affine runs load, for quanta [lo, hi).
QBOND_VECTOR_CLONES void copy_state(const State& state, const StepArrays& a, std::size_t lo, std::size_t hi) {
  const double* x = state.x.data()->data();
  const double* v = state.v.data()->data();
  QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
    QBOND_UNROLL(3)
    for (std::size_t c = 0; c < 3; ++c) {
      a.x[c][q] = x[3 * q + c];
      a.v[c][q] = v[3 * q + c];
    }
  }
}

// Each row's start for quanta [lo, hi): A_ii = m_i I and b_i = m_i v_i + h f_i (Eq. 12 before
// any bond), f_i as External gives it (kGravity: gravity alone); with kCopy the copies of x and v
// too (copy_state), in the same loop, which reads v for both.
template <bool kGravity, bool kCopy>
QBOND_VECTOR_INLINE void start_range(const Model& model, const State& state, External f, double h,
                                     const StepArrays& a, std::size_t lo, std::size_t hi) {
  const double* mass = model.mass.data();
  const double* x = state.x.data()->data();
  const double* v = state.v.data()->data();
  QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
    const double m = mass[q];
    QBOND_UNROLL(3)
    for (std::size_t c = 0; c < 3; ++c) {
      const double vq = v[3 * q + c];
      a.row[c][q] = m;
      a.row[3 + c][q] = 0;
      a.row[6 + c][q] = m * vq + h * f.at<kGravity>(q, c);
      if constexpr (kCopy) {
        a.x[c][q] = x[3 * q + c];
        a.v[c][q] = vq;
      }
    }
  }
}

// start_range for quanta [lo, hi), f_ext empty for gravity alone, with the copies of x and v if
// `copy`.
QBOND_VECTOR_CLONES void start_rows(const Model& model, const State& state, const std::vector<Vec3>& f_ext,
                                    double h, const StepArrays& a, bool copy, std::size_t lo,
                                    std::size_t hi) {
  const External f(model, f_ext);
  if (!f.f) {
    if (copy) return start_range<true, true>(model, state, f, h, a, lo, hi);
    return start_range<true, false>(model, state, f, h, a, lo, hi);
  }
  if (copy) return start_range<false, true>(model, state, f, h, a, lo, hi);
  start_range<false, false>(model, state, f, h, a, lo, hi);
}

// v_i + Δv_i = A_ii⁻¹ b_i for quanta [lo, hi) — the adjugate of the symmetric block (positive
// definite) over its determinant — and, in one vector loop, Δv_i and Δx_i = h (v_i + Δv_i) written
// out or, for a step advanced in place (kApplied), the state the step applies, x_i + Δx_i and
// v_i + Δv_i (the same bits), checked by the blow-up rule (the result; true otherwise). Kinematic
// quanta get zeros, or their x and v (their rows are not theirs to solve): the prescribed ones'
// motion is then written over them (PrescribedAt).
template <bool kApplied>
QBOND_VECTOR_INLINE bool solve_range(const Model& model, const State& state, const StepArrays& a, double h,
                                     double limit2, std::size_t lo, std::size_t hi, Projection& out,
                                     Advanced* to) {
  const double* inv_mass = model.inv_mass.data();
  const double *a0 = a.row[0], *a1 = a.row[1], *a2 = a.row[2], *a3 = a.row[3], *a4 = a.row[4], *a5 = a.row[5];
  const double *bx = a.row[6], *by = a.row[7], *bz = a.row[8];
  // Local copies: read through `a` in the loop, GCC gathers them lane by lane.
  const double *xs[3] = {a.x[0], a.x[1], a.x[2]}, *vs[3] = {a.v[0], a.v[1], a.v[2]};
  const double* v = state.v.data()->data();
  double* dv = kApplied ? nullptr : out.dv.data()->data();
  double* dx = kApplied ? nullptr : out.dx.data()->data();
  double* x_to = kApplied ? to->x.data()->data() : nullptr;
  double* v_to = kApplied ? to->v.data()->data() : nullptr;
  std::uint64_t bad = 0;
  QBOND_SIMD_OR(bad) for (std::size_t q = lo; q < hi; ++q) {
    const double c00 = a1[q] * a2[q] - a5[q] * a5[q], c11 = a0[q] * a2[q] - a4[q] * a4[q];
    const double c22 = a0[q] * a1[q] - a3[q] * a3[q], c01 = a4[q] * a5[q] - a3[q] * a2[q];
    const double c02 = a3[q] * a5[q] - a4[q] * a1[q], c12 = a3[q] * a4[q] - a0[q] * a5[q];
    const double inv_det = 1.0 / (a0[q] * c00 + a3[q] * c01 + a4[q] * c02);
    const double x = bx[q], y = by[q], z = bz[q];
    QuantaCheck check;
    auto write = [&](std::size_t c, double v1) QBOND_LAMBDA_INLINE {
      if constexpr (kApplied) {
        const double x1 = xs[c][q] + h * v1, vq = vs[c][q], v1_applied = vq + (v1 - vq);
        x_to[3 * q + c] = x1;
        v_to[3 * q + c] = v1_applied;
        check.add(x1, v1_applied);
      } else {
        dv[3 * q + c] = v1 - v[3 * q + c];
        dx[3 * q + c] = h * v1;
      }
    };
    write(0, inv_det * (c00 * x + c01 * y + c02 * z));
    write(1, inv_det * (c01 * x + c11 * y + c12 * z));
    write(2, inv_det * (c02 * x + c12 * y + c22 * z));
    // A kinematic quanta's values here are not its own: it is checked below.
    if constexpr (kApplied) bad |= check.bad(limit2, true) & (inv_mass[q] != 0);
  }
  // After the vector loop, not a select in it (GCC would mask the strided loads of v, which it
  // cannot vectorise).
  for (std::size_t q = lo; q < hi; ++q) {
    if (inv_mass[q] != 0) continue;
    if constexpr (kApplied) {
      to->x[q] = state.x[q];
      to->v[q] = state.v[q];
      bad |= static_cast<std::uint64_t>(!state.x[q].allFinite() || !state.v[q].allFinite());
    } else {
      out.dv[q] = out.dx[q] = Vec3::Zero();
    }
  }
  return bad == 0;
}

// solve_range, into the state the step applies if `to` is not null.
QBOND_VECTOR_CLONES bool solve_rows(const Model& model, const State& state, const StepArrays& a, double h,
                                    double limit2, std::size_t lo, std::size_t hi, Projection& out,
                                    Advanced* to) {
  return to ? solve_range<true>(model, state, a, h, limit2, lo, hi, out, to)
            : solve_range<false>(model, state, a, h, limit2, lo, hi, out, to);
}

}  // namespace

void FrozenStep::project(const Model& model, const State& state, const Adjacency& adj,
                         const std::vector<Vec3>& f_ext, const StepContext& ctx, int threads,
                         Projection& out, Advanced* to) {
  const std::size_t n = model.num_quanta();
  const double h = ctx.h;
  const bool in_place = to != nullptr;
  out.resize(in_place ? 0 : n, false);  // solve_rows writes every row
  if (in_place) {
    to->x.resize(n);
    to->v.resize(n);
  }
  part.update(model, state.bonds, adj, threads);
  StepArrays a;
  SoaArrays soa(arrays, n, 15);
  soa.take(a.row);
  soa.take(a.x);
  soa.take(a.v);
  // Each part's rows are started, and its x and v copied, just before its runs reach them, and
  // its rows solved once its later runs no longer reach them (BondRun::reach, settled), in pieces
  // of at least `wake` quanta: the rows and copies are then in the second-level cache through the
  // bond pass, and are not streamed from memory by passes of their own before and after it. A
  // row's sum is the same either way. The quanta other parts' runs join are copied first, so
  // that no part reads an entry another is writing.
  for_each_part(part.parts(), [&](int p) {
    copy_state(state, a, part.first[p], part.alone_lo[p]);
    copy_state(state, a, part.alone_hi[p], part.first[p + 1]);
  });
  const auto start = [&](const FrozenScratch& s, Index lo, Index hi) {
    const Index copy_lo = std::max(lo, part.alone_lo[s.part]), copy_hi = std::min(hi, part.alone_hi[s.part]);
    const bool whole = copy_lo == lo && copy_hi == hi;  // else some are copied above, or empty
    start_rows(model, state, f_ext, h, a, whole, lo, hi);
    if (!whole) copy_state(state, a, copy_lo, copy_hi);
  };
  // m I + Σ B_b with B_b positive semi-definite: symmetric positive definite.
  // The prescribed quanta's rows, or their place in the applied state, with their range's
  // (PrescribedAt says why).
  prescribed.update(model, ctx.t + h);
  const double limit2 = in_place ? to->max_speed * to->max_speed : HUGE_VAL;
  std::atomic<bool> ok = true;  // the applied state's check (in place): an AND, in any order
  const auto solve = [&](Index lo, Index hi) {
    bool range_ok = solve_rows(model, state, a, h, limit2, lo, hi, out, to);
    if (!in_place) return prescribed.project(state, lo, hi, out);
    prescribed.place(lo, hi, to->x.data(), to->v.data());
    for (const PrescribedAt::Quanta& p : prescribed.in(lo, hi))
      range_ok = range_ok && p.x.allFinite() && p.v.allFinite();
    if (!range_ok) ok.store(false, std::memory_order_relaxed);
  };
  for_each_bond_run<FrozenScratch>(part, [&](const BondRun& run, FrozenScratch& s) {
    if (s.part < 0) {
      const auto after = std::upper_bound(part.first.begin(), part.first.end(), run.lo);
      s.part = static_cast<int>(after - part.first.begin()) - 1;
      s.started = s.solved = run.lo;
    }
    if (s.started < std::min(run.reach, run.hi)) {
      const Index to = std::min(run.hi, std::max(run.reach, s.started + wake));
      start(s, s.started, to);
      s.started = to;
    }
    // The same runs for every partition (bond_partition.hpp), so the same path for each bond (an
    // affine run adds its terms from its loop or after it, the same sums either way).
    if (run.kind >= 0) {
      affine_run(state, a, run, h, run.kind == 0, s.terms, s.stretch);
    } else {
      frozen_terms(model, state, run, h, s.bonds, s.terms);
      frozen_scatter(run, s.bonds, s.terms, state.v.data(), a, s.stretch);
    }
    if (run.last) {
      start(s, s.started, run.hi);
      solve(s.solved, run.hi);
      return;
    }
    // Not past the rows started (the rows between that no bond joins are started later), nor past
    // a row whose stretch is still open (its last terms are to come).
    const Index settled = std::min({run.settled, run.hi, s.started, s.stretch.q});
    if (settled >= s.solved + wake) {
      solve(s.solved, settled);
      s.solved = settled;
    }
  });
  // The rows of parts without bonds, and their copies of x and v, which an in-place step's solve
  // reads (the copies before the bond pass take only the quanta other parts' runs join).
  for (int p = 0; p < part.parts(); ++p)
    if (part.run_offset[p] == part.run_offset[p + 1]) {
      start_rows(model, state, f_ext, h, a, /*copy=*/true, part.first[p], part.first[p + 1]);
      solve(part.first[p], part.first[p + 1]);
    }
  if (in_place) to->ok = ok.load(std::memory_order_relaxed);
}

}  // namespace qbond
