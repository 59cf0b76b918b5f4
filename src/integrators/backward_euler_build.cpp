// The coupled implicit step's build (begin_implicit_step in backward_euler.hpp) as one
// bond-centric pass in runs: an affine run (bond_partition.hpp) of linear bonds with one damping
// model is linearised in one vector loop reading its ends' data as contiguous vectors, its terms
// added to the rows (structure of arrays) in bond order by vector loops (affine_run_terms.hpp) and its
// blocks written for CG's product; other runs bond by bond. The Newton integrators' assembly of
// A's diagonal blocks from their bond blocks (assemble_blocks) takes the same runs. Each row
// receives its bonds in bond order, so its sum is the same for any thread count. The vector
// functions are compiled for several instruction sets (simd.hpp).
#include <algorithm>
#include <cmath>

#include "integrators/affine_run_terms.hpp"
#include "integrators/backward_euler.hpp"
#include "integrators/integrator_common.hpp"
#include "core/parallel.hpp"
#include "core/simd.hpp"

namespace qbond {

namespace {

// The build's per-quanta arrays (structure of arrays, soa_stride apart): each row's A_ii (six
// entries: xx, yy, zz, xy, xz, yz) and b_i, and copies of x, v, Δx₀ and Δv_k (backward_euler.hpp)
// from which an affine run loads contiguous vectors.
struct BuildArrays {
  double* row[9];
  double *x[3], *v[3], *dx0[3], *dvk[3];
  BuildArrays(LineVector<double>& buffer, std::size_t n) {
    SoaArrays soa(buffer, n, 21);
    soa.take(row);
    soa.take(x);
    soa.take(v);
    soa.take(dx0);
    soa.take(dvk);
  }
};

// Rows' start for quanta [lo, hi), A_ii = m I and b_i = h f_ext,i as External gives it (kGravity:
// gravity alone), and the copies.
template <bool kGravity>
QBOND_VECTOR_INLINE void start_range(const Model& model, const State& state, External f,
                                     const Projection& kin, double h, const BuildArrays& a, std::size_t lo,
                                     std::size_t hi) {
  const double *mass = model.mass.data(), *inv_mass = model.inv_mass.data();
  const double* x = state.x.data()->data();
  const double* v = state.v.data()->data();
  const double* kdx = kin.dx.data()->data();
  const double* kdv = kin.dv.data()->data();
  QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
    const double m = mass[q];
    QBOND_UNROLL(3) for (std::size_t c = 0; c < 3; ++c) {
      a.row[c][q] = m;
      a.row[3 + c][q] = 0;
      a.row[6 + c][q] = h * f.at<kGravity>(q, c);
      a.x[c][q] = x[3 * q + c];
      const double vq = v[3 * q + c], dx = kdx[3 * q + c], dv = kdv[3 * q + c];  // loaded, then selected
      a.v[c][q] = vq;
      a.dx0[c][q] = inv_mass[q] != 0 ? h * vq : dx;
      a.dvk[c][q] = inv_mass[q] != 0 ? 0.0 : dv;
    }
  }
}

// start_range, f_ext empty for gravity alone.
QBOND_VECTOR_CLONES void start_build(const Model& model, const State& state, const std::vector<Vec3>& f_ext,
                                     const Projection& kin, double h, const BuildArrays& a, std::size_t lo,
                                     std::size_t hi) {
  const External f(model, f_ext);
  if (!f.f) return start_range<true>(model, state, f, kin, h, a, lo, hi);
  start_range<false>(model, state, f, kin, h, a, lo, hi);
}

// A run's terms, by bond k of the run: B_b's six entries, the right-hand-side term g_b on bond_i
// and −g_b on bond_j (−0.0 in the lanes past the run), and the block's u, Ba, Bb.
struct BuildTerms {
  alignas(64) double B[6][kBondRun];
  alignas(64) double gi[3][kBondRun], gj[3][kBondRun];
  alignas(64) double u[3][kBondRun], Ba[kBondRun], Bb[kBondRun];
};

// An affine run of linear bonds with one damping model (kAxial: axial): linearise_bond's
// arithmetic and the build's in one vector loop. Kinematic ends need no mask: their rows are
// replaced after the pass, and Δx₀, Δv_k hold their prescribed motion. (A variant for runs with
// no kinematic end, Δx₀_i − Δx₀_j = −h w and no Δv_k, would gain nothing on an anchored lattice,
// whose x = 0 face is in every run.)
template <bool kAxial>
QBOND_VECTOR_INLINE void linear_affine_build(const State& state, const BuildArrays& a, const BondRun& run, double h,
                                             BuildTerms& t) {
  const RunParameters p(state, run);
  const double *k = p.k, *L = p.L, *D = p.D;  // named, not bound: lambdas capture them (clang 14)
  const double *xi[3], *xj[3], *vi[3], *vj[3], *ei[3], *ej[3], *ci[3], *cj[3];  // local: held in registers
  for (int c = 0; c < 3; ++c) {
    xi[c] = a.x[c] + run.i0, xj[c] = a.x[c] + run.j0;
    vi[c] = a.v[c] + run.i0, vj[c] = a.v[c] + run.j0;
    ei[c] = a.dx0[c] + run.i0, ej[c] = a.dx0[c] + run.j0;
    ci[c] = a.dvk[c] + run.i0, cj[c] = a.dvk[c] + run.j0;
  }
  const double h2 = h * h;
  for_lanes(affine_lanes(run), [&](std::size_t q) QBOND_LAMBDA_INLINE {  // kVectorLoop
    const double kq = k[q], Lq = L[q], Dq = D[q];  // loaded unconditionally: selects, not masked loads
    // Aggregates, not arrays filled by a loop: GCC then vectorises the loop.
    const double d[3] = {xj[0][q] - xi[0][q], xj[1][q] - xi[1][q], xj[2][q] - xi[2][q]};
    const double w[3] = {vj[0][q] - vi[0][q], vj[1][q] - vi[1][q], vj[2][q] - vi[2][q]};
    const double e[3] = {ei[0][q] - ej[0][q], ei[1][q] - ej[1][q], ei[2][q] - ej[2][q]};
    const double dc[3] = {ci[0][q] - cj[0][q], ci[1][q] - cj[1][q], ci[2][q] - cj[2][q]};
    const double r = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    const bool ok = r > 0;  // a zero-length bond does nothing (laws.hpp)
    const double inv_r = ok ? 1.0 / (ok ? r : 1.0) : 0.0;
    const double u[3] = {inv_r * d[0], inv_r * d[1], inv_r * d[2]};
    const double T = ok ? kq * (r - Lq) : 0.0, dT = ok ? kq : 0.0, Dok = ok ? Dq : 0.0;
    const double ca = kAxial ? Dok : 0.0, cb = kAxial ? 0.0 : Dok;
    const StiffnessCoefficients k = clamped_stiffness(dT, T * inv_r);
    const double kb = k.kb(), ka = k.ka();
    const double Ba = h * ca + h2 * ka, Bb = h * cb + h2 * kb;
    const double uw = u[0] * w[0] + u[1] * w[1] + u[2] * w[2];
    const double ue = u[0] * e[0] + u[1] * e[1] + u[2] * e[2];
    const double uc = u[0] * dc[0] + u[1] * dc[1] + u[2] * dc[2];
    const double aux = Ba * u[0], auy = Ba * u[1];
    const double B[6] = {aux * u[0] + Bb, auy * u[1] + Bb, Ba * u[2] * u[2] + Bb, aux * u[1], aux * u[2], auy * u[2]};
    QBOND_UNROLL(6) for (int c = 0; c < 6; ++c) t.B[c][q] = B[c];
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) {
      // f = T u + C_b w; g = h f − h K_b (Δx₀_i − Δx₀_j) − h C_b (Δv_k,i − Δv_k,j).
      const double f = kAxial ? (T + Dok * uw) * u[c] : T * u[c] + Dok * w[c];
      const double Ke = ka * ue * u[c] + kb * e[c], Cc = ca * uc * u[c] + cb * dc[c];
      const double g = h * f - h * Ke - h * Cc;
      t.gi[c][q] = g;
      t.gj[c][q] = -g;
      t.u[c][q] = u[c];
    }
    t.Ba[q] = Ba;
    t.Bb[q] = Bb;
  });
}

// An affine run that uniform_linear accepts (axial: its damping model is axial): its terms added
// to the rows its part owns, in bond order, and the blocks of the bonds whose bond_i it owns
// written (each bond's by one part).
QBOND_VECTOR_INLINE void affine_build(const State& state, const BuildArrays& a,
                                      const BondRun& run, double h, bool axial, BuildTerms& t, BondBlocks& blocks) {
  prefetch_parameters(state, run);
  if (axial)
    linear_affine_build<true>(state, a, run, h, t);
  else
    linear_affine_build<false>(state, a, run, h, t);
  double* const ti[9] = {t.B[0], t.B[1], t.B[2], t.B[3], t.B[4], t.B[5], t.gi[0], t.gi[1], t.gi[2]};
  double* const tj[9] = {t.B[0], t.B[1], t.B[2], t.B[3], t.B[4], t.B[5], t.gj[0], t.gj[1], t.gj[2]};
  add_affine_run(run, a.row, ti, tj);
  const Index k0 = run.lo > run.i0 ? std::min(run.lo - run.i0, run.count) : 0;
  const Index k1 = run.hi > run.i0 ? std::min(run.hi - run.i0, run.count) : 0;
  double* out[5] = {blocks.ux.data() + run.first, blocks.uy.data() + run.first, blocks.uz.data() + run.first,
                    blocks.Ba.data() + run.first, blocks.Bb.data() + run.first};
  const double* in[5] = {t.u[0], t.u[1], t.u[2], t.Ba, t.Bb};
  QBOND_SIMD for (Index q = k0; q < k1; ++q) {
    QBOND_UNROLL(5) for (int e = 0; e < 5; ++e) out[e][q] = in[e][q];
  }
}

// Any other run, bond by bond (linearise_bond): both ends' rows where the part owns them (free
// ones only; kinematic rows are replaced after the pass), the block where it owns bond_i.
void run_build(const Model& model, const State& state, const BuildArrays& a, const BondRun& run, double h,
               BondBlocks& blocks) {
  const double h2 = h * h;
  auto motion = [&](double* const (&arr)[3], Index i) { return Vec3(arr[0][i], arr[1][i], arr[2][i]); };
  for (Index k = 0; k < run.count; ++k) {
    const Index b = run.bond(k), i = state.bonds.i[b], j = state.bonds.j[b];
    const bool own_i = run.owns(i), own_j = run.owns(j);
    const BondLinearisation l = linearise_bond(model, state, b);
    const double Ba = h * l.ca + h2 * l.ka, Bb = h * l.cb + h2 * l.kb;
    if (own_i) blocks.set(b, l.u, Ba, Bb);
    const bool free_i = !model.is_kinematic(i), free_j = !model.is_kinematic(j);
    if (!(own_i && free_i) && !(own_j && free_j)) continue;
    double B[6];
    block_entries(l.u, Ba, Bb, B);
    Vec3 g = h * l.f - h * block_times(l.u, l.ka, l.kb, motion(a.dx0, i) - motion(a.dx0, j));
    if (!free_i || !free_j) g -= h * block_times(l.u, l.ca, l.cb, motion(a.dvk, i) - motion(a.dvk, j));
    auto add = [&](Index q, const Vec3& gq) {
      for (int e = 0; e < 6; ++e) a.row[e][q] += B[e];
      for (int c = 0; c < 3; ++c) a.row[6 + c][q] += gq[c];
    };
    if (own_i && free_i) add(i, g);
    if (own_j && free_j) add(j, -g);
  }
}

// A's diagonal blocks from the rows' six entries, and their inverses, for free quanta (identity
// for kinematic ones); with rhs, b from the rows' last three (0 for kinematic quanta).
void finish_rows(const Model& model, const BuildArrays& a, int threads, bool rhs, ImplicitSystem& sys) {
  const std::size_t n = model.num_quanta();
  sys.diag.resize(n);
  sys.diag_inv.resize(n);
  if (rhs) sys.rhs.resize(n);
  parallel_for(n, threads, [&](std::size_t q) {
    if (model.is_kinematic(static_cast<Index>(q))) {
      sys.diag[q].setIdentity();
      sys.diag_inv[q].setIdentity();
      if (rhs) sys.rhs[q].setZero();
      return;
    }
    const auto r = [&](int e) { return a.row[e][q]; };
    sys.diag[q] << r(0), r(3), r(4), r(3), r(1), r(5), r(4), r(5), r(2);
    // A_ii = m I + Σ B_b with B_b positive semi-definite: symmetric positive definite.
    sys.diag_inv[q] = sys.diag[q].inverse();
    if (rhs) sys.rhs[q] = Vec3(r(6), r(7), r(8));
  });
}

// Rows' start for assemble_blocks, A_ii = m I, for quanta [lo, hi).
QBOND_VECTOR_CLONES void start_blocks(const Model& model, const BuildArrays& a, std::size_t lo, std::size_t hi) {
  const double* mass = model.mass.data();
  QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
    QBOND_UNROLL(3) for (std::size_t c = 0; c < 3; ++c) {
      a.row[c][q] = mass[q];
      a.row[3 + c][q] = 0;
    }
  }
}

// An affine run's blocks B_b (six entries from u, Ba, Bb; −0.0 in the lanes past the run) added to
// both ends' rows its part owns, in bond order.
QBOND_VECTOR_INLINE void affine_blocks(const BondRun& run, const BondBlocks& blocks, const BuildArrays& a,
                                       BuildTerms& t) {
  const double *ux = blocks.ux.data() + run.first, *uy = blocks.uy.data() + run.first,
               *uz = blocks.uz.data() + run.first;
  const double *Ba = blocks.Ba.data() + run.first, *Bb = blocks.Bb.data() + run.first;
  for_lanes(affine_lanes(run), [&](std::size_t q) QBOND_LAMBDA_INLINE {  // kVectorLoop
    const double aux = Ba[q] * ux[q], auy = Ba[q] * uy[q];
    const double B[6] = {aux * ux[q] + Bb[q], auy * uy[q] + Bb[q], Ba[q] * uz[q] * uz[q] + Bb[q],
                         aux * uy[q],         aux * uz[q],         auy * uz[q]};
    QBOND_UNROLL(6) for (int e = 0; e < 6; ++e) t.B[e][q] = B[e];
  });
  double* const rows[6] = {a.row[0], a.row[1], a.row[2], a.row[3], a.row[4], a.row[5]};
  double* const tb[6] = {t.B[0], t.B[1], t.B[2], t.B[3], t.B[4], t.B[5]};
  add_affine_run(run, rows, tb, tb);
}

// Any other run's blocks, bond by bond, added to the rows its part owns.
void run_blocks(const Bonds& bonds, const BondRun& run, const BondBlocks& blocks, const BuildArrays& a) {
  for (Index k = 0; k < run.count; ++k) {
    const Index b = run.bond(k);
    double B[6];
    block_entries(blocks.u(b), blocks.Ba[b], blocks.Bb[b], B);
    for (const Index q : {bonds.i[b], bonds.j[b]})
      if (run.owns(q))
        for (int e = 0; e < 6; ++e) a.row[e][q] += B[e];
  }
}

// A part's runs' blocks (for_each_part_runs).
QBOND_VECTOR_CLONES void part_blocks(const Bonds& bonds, std::span<const BondRun> runs,
                                     const BondBlocks& blocks, const BuildArrays& a, BuildTerms& t) {
  for (const BondRun& run : runs)
    if (run.affine)
      affine_blocks(run, blocks, a, t);
    else
      run_blocks(bonds, run, blocks, a);
}

// A part's runs' terms and blocks (for_each_part_runs). The same runs for every partition
// (bond_partition.hpp), so the same path for each bond.
QBOND_VECTOR_CLONES void part_build(const Model& model, const State& state, const BuildArrays& a,
                                    std::span<const BondRun> runs, double h, BuildTerms& t,
                                    BondBlocks& blocks) {
  for (const BondRun& run : runs) {
    if (run.kind >= 0)
      affine_build(state, a, run, h, run.kind == 0, t, blocks);
    else
      run_build(model, state, a, run, h, blocks);
  }
}

}  // namespace

void assemble_blocks(const Model& model, const Bonds& bonds, const Adjacency& adj, int threads, bool edges,
                     ImplicitSystem& sys) {
  const std::size_t n = model.num_quanta();
  sys.part.update(model, bonds, adj, threads);
  const BuildArrays a(sys.arrays, n);
  parallel_ranges(n, threads, [&](std::size_t lo, std::size_t hi) { start_blocks(model, a, lo, hi); });
  for_each_part_runs<BuildTerms>(sys.part, [&](std::span<const BondRun> runs, BuildTerms& t) {
    part_blocks(bonds, runs, sys.bonds, a, t);
  });
  finish_rows(model, a, threads, false, sys);
  if (edges) gather_edges(model, adj, threads, sys);
}

void begin_implicit_step(const Model& model, const State& state, const Adjacency& adj,
                         const std::vector<Vec3>& f_ext, const StepContext& ctx, bool edges, int threads,
                         Projection& kin, ImplicitSystem& sys) {
  const std::size_t n = model.num_quanta();
  kin.resize(n, false);  // the free rows are the solve's to write (write_free_rows)
  const double h = ctx.h;
  sys.part.update(model, state.bonds, adj, threads);
  sys.bonds.resize(state.bonds.size());
  sys.couplings.clear();  // a contact solve adds its own
  const BuildArrays a(sys.arrays, n);
  // The kinematic rows (project_kinematic's), each range's by the thread that reads them first
  // (PrescribedAt says why).
  sys.prescribed.update(model, ctx.t + h);
  parallel_ranges(n, threads, [&](std::size_t lo, std::size_t hi) {
    for (std::size_t q = lo; q < hi; ++q)
      if (model.is_kinematic(static_cast<Index>(q))) kin.dx[q] = kin.dv[q] = Vec3::Zero();
    sys.prescribed.project(state, lo, hi, kin);
    start_build(model, state, f_ext, kin, h, a, lo, hi);
  });
  for_each_part_runs<BuildTerms>(sys.part, [&](std::span<const BondRun> runs, BuildTerms& t) {
    part_build(model, state, a, runs, h, t, sys.bonds);
  });
  finish_rows(model, a, threads, true, sys);
  sys.rhs_norm = std::sqrt(deterministic_sum(n, threads, [&](std::size_t i) { return sys.rhs[i].squaredNorm(); }));
  sys.load_norm = h * std::sqrt(deterministic_sum(n, threads, [&](std::size_t i) {
    return model.inv_mass[i] != 0 ? external_force(model, f_ext, static_cast<Index>(i)).squaredNorm() : 0.0;
  }));
  if (edges) gather_edges(model, adj, threads, sys);
}

}  // namespace qbond
