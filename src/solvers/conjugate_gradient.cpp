// Matrix-free block-Jacobi-preconditioned CG (ConjugateGradient in backward_euler.hpp) on
// structure-of-arrays vectors: the product's bond pass takes an affine run (bond_partition.hpp)
// in one vector loop (a grid of them in one loop over its rows) reading its blocks and both ends'
// entries as contiguous vectors and adds the terms to the rows in bond order (affine_run_terms.hpp),
// the other runs bond by bond; the per-quanta loops and the dot products are vector loops too.
// Each row receives its bonds in bond order and each dot product is summed over fixed chunks in
// fixed lanes, so the iterates are the same bits for any thread count. The vector functions are
// compiled for several instruction sets (simd.hpp).
#include <algorithm>
#include <array>
#include <cmath>

#include "integrators/affine_run_terms.hpp"
#include "integrators/backward_euler.hpp"
#include "core/parallel.hpp"
#include "core/simd.hpp"

namespace qbond {

namespace {

// A vector of the solve as structure of arrays: component c of quanta q at [c][q].
using Soa = double* [3];

// A's diagonal blocks as their six distinct entries (xx, yy, zz, xy, xz, yz), and their inverses.
struct Diagonals {
  double* D[6];
  double* Dinv[6];
};

// The symmetric block (xx, yy, zz, xy, xz, yz entries of s at q) times (v0, v1, v2) at q, into out.
QBOND_VECTOR_INLINE void sym_times(const Local<6>& s, std::size_t q, double v0, double v1, double v2,
                                   double (&out)[3]) {
  out[0] = s[0][q] * v0 + s[3][q] * v1 + s[4][q] * v2;
  out[1] = s[3][q] * v0 + s[1][q] * v1 + s[5][q] * v2;
  out[2] = s[4][q] * v0 + s[5][q] * v1 + s[2][q] * v2;
}

// out_q = A_qq y_q over [lo, hi) (0 for kinematic quanta, whose y_q is 0).
QBOND_VECTOR_CLONES void diagonal_times(const Diagonals& d, const Soa& y_in, const Soa& out_in,
                                        std::size_t lo, std::size_t hi) {
  const Local<6> D(d.D);
  const Local<3> y(y_in), out(out_in);
  QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
    double Dy[3];
    sym_times(D, q, y[0][q], y[1][q], y[2][q], Dy);
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) out[c][q] = Dy[c];
  }
}

// A run's off-diagonal terms, by bond k of the run: −B_b y_j onto bond_i's row, −B_b y_i onto
// bond_j's.
struct ProductTerms {
  alignas(64) double ti[3][kBondRun], tj[3][kBondRun];
};

// Asks for the blocks of the bonds a few runs on: the product streams five arrays of them beside
// a dozen other streams, more than the hardware prefetcher follows far enough ahead.
QBOND_VECTOR_INLINE void prefetch_blocks(const BondBlocks& blocks, const BondRun& run) {
  constexpr std::size_t kAhead = 4 * kBondRun;
  const std::size_t b = run.first + kAhead;
  if (b + run.count > blocks.Ba.size()) return;
  for (std::size_t k = 0; k < run.count; k += 8)  // a cache line of doubles
    for (const std::vector<double>* a : {&blocks.ux, &blocks.uy, &blocks.uz, &blocks.Ba, &blocks.Bb})
      __builtin_prefetch(a->data() + b + k);
}

// An affine run's −B_b y_j and −B_b y_i, bond q's as add_affine_terms takes them: the run's
// blocks from ux, uy, uz, Ba, Bb on, its ends i0 + q and j0 + q. No end is tested: a kinematic
// quanta's unknown is eliminated and its entry of y is 0 (CG's vectors keep it 0), so a free row
// receives ∓0 from it, and what the bond adds to a kinematic row is never read.
struct AffineProduct {
  const double *ux, *uy, *uz, *Ba, *Bb;
  Local<3> y;
  std::size_t i0, j0;

  AffineProduct(const BondRun& run, const BondBlocks& blocks, const Soa& y_in)
      : ux(blocks.ux.data() + run.first),
        uy(blocks.uy.data() + run.first),
        uz(blocks.uz.data() + run.first),
        Ba(blocks.Ba.data() + run.first),
        Bb(blocks.Bb.data() + run.first),
        y(y_in),
        i0(run.i0),
        j0(run.j0) {}
  QBOND_VECTOR_INLINE void operator()(std::size_t q, double (&ti)[3], double (&tj)[3]) const {
    const std::size_t i = i0 + q, j = j0 + q;
    const double u[3] = {ux[q], uy[q], uz[q]};
    const double a = Ba[q], b = Bb[q];
    const double ui = u[0] * y[0][i] + u[1] * y[1][i] + u[2] * y[2][i];
    const double uj = u[0] * y[0][j] + u[1] * y[1][j] + u[2] * y[2][j];
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) {
      ti[c] = -(a * uj * u[c] + b * y[c][j]);
      tj[c] = -(a * ui * u[c] + b * y[c][i]);
    }
  }
  // On to the next run of a grid: bonds count on, ends stride on.
  QBOND_VECTOR_INLINE void next_row(Index count, Index stride) {
    for (const double** p : {&ux, &uy, &uz, &Ba, &Bb}) *p += count;
    i0 += stride;
    j0 += stride;
  }
};

// An affine run's products added to the rows the part owns in bond order: from the loop that
// forms them when the run is fusable, else from the run's term arrays.
QBOND_VECTOR_INLINE void affine_product(const BondRun& run, const BondBlocks& blocks, const Soa& y,
                                        const Soa& out, ProductTerms& t) {
  prefetch_blocks(blocks, run);
  add_affine_terms(run, out, AffineProduct(run, blocks, y), {t.ti[0], t.ti[1], t.ti[2]},
                   {t.tj[0], t.tj[1], t.tj[2]});
}

// A grid's runs (BondRun::rows), each fusable, one after the other as affine_product takes them,
// with their pointers set up once (a small body's runs are a vector each, so a run's set-up
// costs as much as its arithmetic); kept apart from the other runs' path and its term arrays.
QBOND_VECTOR_INLINE void grid_product(std::span<const BondRun> grid, const BondBlocks& blocks, const Soa& y,
                                      const Soa& out) {
  const Index stride = grid[1].i0 - grid[0].i0;
  AffineProduct terms(grid[0], blocks, y);
  for (const BondRun& row : grid) {
    prefetch_blocks(blocks, row);
    add_affine_fused(row, out, terms);
    terms.next_row(row.count, stride);
  }
}

// Any other run, bond by bond: −B_b y_j onto row i and −B_b y_i onto row j where the part owns
// them, for bonds between free quanta.
void run_product(const Model& model, const Bonds& bonds, const BondRun& run, const BondBlocks& blocks,
                 const Soa& y, const Soa& out) {
  const double* inv_mass = model.inv_mass.data();
  for (Index k = 0; k < run.count; ++k) {
    const Index b = run.bond(k), i = bonds.i[b], j = bonds.j[b];
    if (inv_mass[i] == 0 || inv_mass[j] == 0) continue;  // eliminated unknowns
    const Vec3 u = blocks.u(b);
    const Vec3 yi(y[0][i], y[1][i], y[2][i]), yj(y[0][j], y[1][j], y[2][j]);
    const Vec3 fi = block_times(u, blocks.Ba[b], blocks.Bb[b], yj), fj = block_times(u, blocks.Ba[b], blocks.Bb[b], yi);
    // Each entry receives its terms in the same order as row by row.
    if (run.owns(i))
      for (int c = 0; c < 3; ++c) out[c][i] -= fi[c];
    if (run.owns(j))
      for (int c = 0; c < 3; ++c) out[c][j] -= fj[c];
  }
}

// A part's runs' products (for_each_part_runs).
QBOND_VECTOR_CLONES void part_product(const Model& model, const Bonds& bonds, std::span<const BondRun> runs,
                                      const BondBlocks& blocks, const Soa& y, const Soa& out,
                                      ProductTerms& t) {
  for (std::size_t r = 0; r < runs.size();) {
    const BondRun& run = runs[r];
    if (run.rows > 1 && fusable(run) && fusable(runs[r + run.rows - 1])) {  // each row between too
      grid_product(runs.subspan(r, run.rows), blocks, y, out);
      r += run.rows;
      continue;
    }
    if (run.affine)
      affine_product(run, blocks, y, out, t);
    else
      run_product(model, bonds, run, blocks, y, out);
    ++r;
  }
}

// out += the bonds' part of A y, out holding A_qq y: A y over free quanta. y's kinematic rows
// must be 0; out's are left as the bonds make them: its readers ignore them (first_residual and
// cg_update keep r's kinematic rows 0, store writes 0, and the dot products multiply them by p's
// or y's 0).
void bond_product(const Model& model, const Bonds& bonds, const ImplicitSystem& sys, const Soa& y, const Soa& out) {
  for_each_part_runs<ProductTerms>(sys.part, [&](std::span<const BondRun> runs, ProductTerms& t) {
    part_product(model, bonds, runs, sys.bonds, y, out, t);
  });
  // Contacts between quanta: few next to the bonds, added in order after them (the same bits
  // for any thread count); a kinematic end's y is 0.
  for (const PairCoupling& c : sys.couplings) {
    const Vec3 yi(y[0][c.i], y[1][c.i], y[2][c.i]), yj(y[0][c.j], y[1][c.j], y[2][c.j]);
    const Vec3 bi = block_times(c.u, c.a, c.b, yj), bj = block_times(c.u, c.a, c.b, yi);
    for (int k = 0; k < 3; ++k) {
      out[k][c.i] -= bi[k];
      out[k][c.j] -= bj[k];
    }
  }
}

// out = A y (bond_product's conditions).
void product(const Model& model, const Bonds& bonds, const ImplicitSystem& sys, const Diagonals& d,
             const Soa& y, const Soa& out, int threads) {
  parallel_ranges(model.num_quanta(), threads,
                  [&](std::size_t lo, std::size_t hi) { diagonal_times(d, y, out, lo, hi); });
  bond_product(model, bonds, sys, y, out);
}

// N sums Σ_q t_k(q) over [lo, hi), term(q, t) writing t_0(q) .. t_{N-1}(q) (and whatever else q's
// iteration does), each in eight lanes (q's in lane q − lo mod 8) added in lane order: a chunk of
// the dot products.
template <std::size_t N, class Term>
QBOND_VECTOR_INLINE std::array<double, N> lane_sums(std::size_t lo, std::size_t hi, Term&& term) {
  static_assert(N <= 2);  // the unrolled copy below
  double lanes[N][8] = {};
  std::size_t q = lo;
  for (; q + 8 <= hi; q += 8) {
    // The terms first, then their sums: GCC vectorises no loop that adds into two lane arrays as
    // it computes (energy_sums.cpp).
    double t[N][8];
    QBOND_SIMD for (std::size_t l = 0; l < 8; ++l) {
      double tl[N];
      term(q + l, tl);
      QBOND_UNROLL(2) for (std::size_t k = 0; k < N; ++k) t[k][l] = tl[k];
    }
    for (std::size_t k = 0; k < N; ++k) QBOND_SIMD for (std::size_t l = 0; l < 8; ++l) lanes[k][l] += t[k][l];
  }
  for (std::size_t l = 0; q < hi; ++q, ++l) {
    double tl[N];
    term(q, tl);
    for (std::size_t k = 0; k < N; ++k) lanes[k][l] += tl[k];
  }
  std::array<double, N> s{};
  for (std::size_t k = 0; k < N; ++k)
    for (double l : lanes[k]) s[k] += l;
  return s;
}

// a_q · b_q, its components' products added in order.
QBOND_VECTOR_INLINE double dot3(const double (&a)[3], const double (&b)[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// Σ_q a_q · b_q over [lo, hi) (lane_sum).
QBOND_VECTOR_CLONES double lane_dot(const Soa& a_in, const Soa& b_in, std::size_t lo, std::size_t hi) {
  const Local<3> a(a_in), b(b_in);
  return lane_sums<1>(lo, hi, [&](std::size_t k, double(&t)[1]) QBOND_LAMBDA_INLINE {
    t[0] = dot3({a[0][k], a[1][k], a[2][k]}, {b[0][k], b[1][k], b[2][k]});
  })[0];
}

// Σ_q a_q · b_q over fixed chunks: the same bits for any thread count.
double dot(std::size_t n, int threads, const Soa& a, const Soa& b) {
  return reduce_chunks(
      n, threads, 0.0, [&](std::size_t lo, std::size_t hi) { return lane_dot(a, b, lo, hi); },
      [](double x, double y) { return x + y; });
}

// The solve's start for quanta [lo, hi): y (0 for kinematic quanta, whose unknowns are
// eliminated: the product reads them), A's diagonal blocks and their inverses, and the inverse
// masses as structure of arrays.
QBOND_VECTOR_CLONES void load(const Model& model, const ImplicitSystem& sys, const std::vector<Vec3>& y0, const Soa& y_in,
                              const Diagonals& d, double* inv_mass, std::size_t lo, std::size_t hi) {
  const double* D = sys.diag.data()->data();  // Mat3: column-major, symmetric
  const double* Dinv = sys.diag_inv.data()->data();
  const double* yp = y0.data()->data();
  const Local<6> Ds(d.D), Dinvs(d.Dinv);
  const Local<3> y(y_in);
  constexpr int kEntry[6] = {0, 4, 8, 3, 6, 7};  // xx, yy, zz, xy, xz, yz in a column-major 3×3
  QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
    QBOND_UNROLL(6) for (int e = 0; e < 6; ++e) {
      Ds[e][q] = D[9 * q + kEntry[e]];
      Dinvs[e][q] = Dinv[9 * q + kEntry[e]];
    }
    const double im = model.inv_mass[q];
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) {
      const double yq = yp[3 * q + c];  // loaded, then selected (simd.hpp)
      y[c][q] = im != 0 ? yq : 0.0;
    }
    inv_mass[q] = im;
  }
}

// y ← s y and Ay ← s Ay over [lo, hi): CG's guess scaled (conjugate_gradient).
QBOND_VECTOR_CLONES void scale_guess(double s, const Soa& y_in, const Soa& Ay_in, std::size_t lo,
                                     std::size_t hi) {
  const Local<3> y(y_in), Ay(Ay_in);
  QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) {
      y[c][q] *= s;
      Ay[c][q] *= s;
    }
  }
}

// r = b − A y for free quanta (0 for kinematic ones), z = A_qq⁻¹ r, p = z, over [lo, hi), and
// A_qq p into Ap for the first product (bond_product), where A y was (not read with y_zero, y = 0:
// r = b, as b − A·0 has the same bits).
QBOND_VECTOR_CLONES void first_residual(const ImplicitSystem& sys, const double* inv_mass, const Diagonals& d,
                                        bool y_zero, const Soa& Ap_in, const Soa& r_in, const Soa& z_in,
                                        const Soa& p_in, std::size_t lo, std::size_t hi) {
  const double* b = sys.rhs.data()->data();
  const Local<6> D(d.D), Dinv(d.Dinv);
  const Local<3> Ap(Ap_in), r(r_in), z(z_in), p(p_in);
  QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
    double rq[3], zq[3], Dz[3];
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) {
      const double bq = b[3 * q + c], Ayq = y_zero ? 0.0 : Ap[c][q];  // loaded, then selected (simd.hpp)
      r[c][q] = rq[c] = inv_mass[q] != 0 ? bq - Ayq : 0.0;
    }
    sym_times(Dinv, q, rq[0], rq[1], rq[2], zq);
    sym_times(D, q, zq[0], zq[1], zq[2], Dz);
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) {
      p[c][q] = z[c][q] = zq[c];
      Ap[c][q] = Dz[c];
    }
  }
}

// y += α p, r −= α Ap (kinematic rows stay 0: the product leaves theirs of Ap as the bonds make
// them), z = A_qq⁻¹ r over [lo, hi), and that chunk's r·z and r·r as lane_dot sums them: the
// update and the two dot products in one pass over the vectors.
QBOND_VECTOR_CLONES std::array<double, 2> cg_update(double alpha, const double* inv_mass, const Diagonals& d,
                                                    const Soa& p_in, const Soa& Ap_in, const Soa& y_in,
                                                    const Soa& r_in, const Soa& z_in, std::size_t lo,
                                                    std::size_t hi) {
  const Local<6> Dinv(d.Dinv);
  const Local<3> p(p_in), Ap(Ap_in), y(y_in), r(r_in), z(z_in);
  return lane_sums<2>(lo, hi, [&](std::size_t q, double(&t)[2]) QBOND_LAMBDA_INLINE {
    double rq[3], zq[3];
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) {
      y[c][q] += alpha * p[c][q];
      const double rn = r[c][q] - alpha * Ap[c][q];
      r[c][q] = rq[c] = inv_mass[q] != 0 ? rn : 0.0;
    }
    sym_times(Dinv, q, rq[0], rq[1], rq[2], zq);
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) z[c][q] = zq[c];
    t[0] = dot3(rq, zq);
    t[1] = dot3(rq, rq);
  });
}

// p = z + β p, and A_qq p into Ap for the next product (bond_product), over [lo, hi).
QBOND_VECTOR_CLONES void new_direction(double beta, const Diagonals& d, const Soa& z_in, const Soa& p_in,
                                       const Soa& Ap_in, std::size_t lo, std::size_t hi) {
  const Local<6> D(d.D);
  const Local<3> z(z_in), p(p_in), Ap(Ap_in);
  QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
    double pq[3], Dp[3];
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) p[c][q] = pq[c] = z[c][q] + beta * p[c][q];
    sym_times(D, q, pq[0], pq[1], pq[2], Dp);
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) Ap[c][q] = Dp[c];
  }
}

// Back to one Vec3 a quanta (0 for kinematic quanta), over [lo, hi).
QBOND_VECTOR_CLONES void store(const double* inv_mass, const Soa& y_in, std::vector<Vec3>& out,
                               std::size_t lo, std::size_t hi) {
  const Local<3> y(y_in);
  double* o = out.data()->data();
  QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) {
      const double yq = y[c][q];
      o[3 * q + c] = inv_mass[q] != 0 ? yq : 0.0;
    }
  }
}

// The solve's arrays in one buffer of soa_stride(n) slots (affine runs read up to a vector past
// the last quanta).
struct CgArrays {
  double *y[3], *r[3], *z[3], *p[3], *Ap[3];
  Diagonals d;
  double* inv_mass;
  CgArrays(LineVector<double>& buffer, std::size_t n) {
    SoaArrays soa(buffer, n, 28);
    soa.take(y);
    soa.take(r);
    soa.take(z);
    soa.take(p);
    soa.take(Ap);
    soa.take(d.D);
    soa.take(d.Dinv);
    inv_mass = soa.next();
  }
};

}  // namespace

void apply_system(const Model& model, const Bonds& bonds, const ImplicitSystem& sys,
                  const std::vector<Vec3>& y, int threads, std::vector<Vec3>& out) {
  const std::size_t n = model.num_quanta();
  LineVector<double> buffer;
  CgArrays a(buffer, n);
  parallel_ranges(n, threads, [&](std::size_t lo, std::size_t hi) { load(model, sys, y, a.y, a.d, a.inv_mass, lo, hi); });
  product(model, bonds, sys, a.d, a.y, a.Ap, threads);
  out.resize(n);
  parallel_ranges(n, threads, [&](std::size_t lo, std::size_t hi) { store(a.inv_mass, a.Ap, out, lo, hi); });
}

void SystemProduct::prepare(const Model& model, const Bonds& bonds, const ImplicitSystem& sys,
                            const std::vector<Index>& quanta, int threads) {
  model_ = &model;
  bonds_ = &bonds;
  sys_ = &sys;
  quanta_ = &quanta;
  const std::size_t n = model.num_quanta();
  SoaArrays soa(buffer_, n, 12);
  soa.take(y_);
  soa.take(out_);
  soa.take(D_);
  constexpr int kEntry[6] = {0, 4, 8, 3, 6, 7};  // xx, yy, zz, xy, xz, yz in a column-major 3×3
  parallel_for(n, threads, [&](std::size_t q) {
    const double* D = sys.diag[q].data();
    for (int e = 0; e < 6; ++e) D_[e][q] = D[kEntry[e]];
    for (int c = 0; c < 3; ++c) y_[c][q] = 0.0;  // kinematic quanta's stay 0: the product reads them
  });
}

void SystemProduct::apply(const double* y, double* out, int threads) {
  const std::vector<Index>& quanta = *quanta_;
  parallel_for(quanta.size(), threads, [&](std::size_t r) {
    for (int c = 0; c < 3; ++c) y_[c][quanta[r]] = y[3 * r + static_cast<std::size_t>(c)];
  });
  Diagonals d{};
  for (int e = 0; e < 6; ++e) d.D[e] = D_[e];
  product(*model_, *bonds_, *sys_, d, y_, out_, threads);
  parallel_for(quanta.size(), threads, [&](std::size_t r) {
    for (int c = 0; c < 3; ++c) out[3 * r + static_cast<std::size_t>(c)] = out_[c][quanta[r]];
  });
}

void conjugate_gradient(const Model& model, const Bonds& bonds, ImplicitSystem& sys, double tolerance,
                        int cap, int threads, std::vector<Vec3>& y, bool y_zero, SolveStats& stats) {
  const std::size_t n = model.num_quanta();
  CgArrays a(sys.arrays, n);
  auto ranges = [&](auto&& body) { parallel_ranges(n, threads, body); };
  ranges([&](std::size_t lo, std::size_t hi) { load(model, sys, y, a.y, a.d, a.inv_mass, lo, hi); });
  // A guess is first scaled by s = yᵀb / yᵀA y, which minimises the error's A-norm along it: the
  // start is then never worse than zero in that norm (a previous step's Δv at another step length,
  // or after an impulse, can be), and often better than the guess as it is.
  if (!y_zero) {
    product(model, bonds, sys, a.d, a.y, a.Ap, threads);
    const double yAy = dot(n, threads, a.y, a.Ap);
    const double yb = deterministic_sum(n, threads, [&](std::size_t i) {
      return model.inv_mass[i] != 0 ? y[i].dot(sys.rhs[i]) : 0.0;
    });
    const double s = yAy > 0 ? yb / yAy : 0.0;
    ranges([&](std::size_t lo, std::size_t hi) { scale_guess(s, a.y, a.Ap, lo, hi); });
  }
  ranges([&](std::size_t lo, std::size_t hi) {
    first_residual(sys, a.inv_mass, a.d, y_zero, a.Ap, a.r, a.z, a.p, lo, hi);
  });
  // Dot products over free quanta: kinematic rows of r, z, p and Ap are 0.
  double rz = dot(n, threads, a.r, a.z);
  const double bnorm = sys.residual_scale();
  auto rel = [&](double r2) { return bnorm > 0 ? std::sqrt(r2) / bnorm : std::sqrt(r2); };
  stats.residual = rel(dot(n, threads, a.r, a.r));
  // An iteration in four passes, so four parallel regions: p's new direction with A_qq p (after
  // the first, whose are first_residual's), the bonds' part of A p, pᵀA p, and the update with
  // rᵀz and rᵀr. The same arithmetic and sums as separate passes for each: the same bits.
  using Sums2 = std::array<double, 2>;
  auto plus2 = [](const Sums2& u, const Sums2& v) { return Sums2{u[0] + v[0], u[1] + v[1]}; };
  int it = 0;
  double beta = 0;
  while (it < cap && stats.residual > tolerance) {
    if (it > 0)
      ranges([&](std::size_t lo, std::size_t hi) { new_direction(beta, a.d, a.z, a.p, a.Ap, lo, hi); });
    bond_product(model, bonds, sys, a.p, a.Ap);
    const double pAp = dot(n, threads, a.p, a.Ap);
    if (!(pAp > 0)) break;  // exact solution reached (p = 0) or loss of positivity
    const double alpha = rz / pAp;
    const Sums2 sums = reduce_chunks(
        n, threads, Sums2{},
        [&](std::size_t lo, std::size_t hi) {
          return cg_update(alpha, a.inv_mass, a.d, a.p, a.Ap, a.y, a.r, a.z, lo, hi);
        },
        plus2);
    beta = sums[0] / rz;
    rz = sums[0];
    ++it;
    stats.residual = rel(sums[1]);
  }
  stats.iterations = it;
  ranges([&](std::size_t lo, std::size_t hi) { store(a.inv_mass, a.y, y, lo, hi); });
}

}  // namespace qbond
