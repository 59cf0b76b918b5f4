#pragma once
// Pieces the bond kernels share for affine runs (bond_partition.hpp: bond first + k joins i0 + k
// and j0 + k): which runs take the vector path, and adding a run's per-bond terms to both ends'
// per-quanta rows (structure of arrays) by vector loops, in bond order. Inlined into each
// kernel's clones (simd.hpp). Used by the frozen hybrid step (hybrid_frozen_kernel.cpp) and the explicit
// force pass (bond_forces.cpp).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "integrators/bond_partition.hpp"
#include "qbond/core/line_vector.hpp"
#include "qbond/model/world.hpp"
#include "core/simd.hpp"

namespace qbond {

// The lanes an affine run's loops take (bond_partition.hpp): its count rounded up to a multiple
// of 4 (for_each_bond_run's affine runs have that many bonds, and the kernels' arrays are padded).
// The lanes past the run get terms of −0.0, which added to a row leave its bits as they are
// (x + (−0.0) = x for every double x, +0.0 included).
inline Index affine_lanes(const BondRun& run) { return affine_lanes(run.count); }

// lane(q) for q in [0, lanes), lanes a multiple of 4, as loops of a known trip count (marked
// kVectorLoop where they are written): vectors of 8, then one of 4 if lanes is not a multiple of
// 8. The compiler vectorises such loops with no remainder, profitability check or scalar
// fallback, which it does not do for a loop to `lanes` (it does not see that it is a multiple
// of 4).
template <class Lane>
QBOND_VECTOR_INLINE void for_lanes(std::size_t lanes, Lane&& lane) {
  const std::size_t whole = lanes & ~std::size_t{7};
  for (std::size_t q0 = 0; q0 < whole; q0 += 8) QBOND_SIMD for (std::size_t l = 0; l < 8; ++l) lane(q0 + l);
  if (whole != lanes) QBOND_SIMD for (std::size_t l = 0; l < 4; ++l) lane(whole + l);
}

// lane(q) for q in [0, lanes) as for_lanes takes them, each after lead(q), which prepares what it
// reads (AffineLengths): a vector of 8 lanes' lead in the iteration before theirs, so that the two
// overlap (lead's square roots and divisions use the divider, lane's arithmetic the other units).
template <class Lead, class Lane>
QBOND_VECTOR_INLINE void for_lanes_led(std::size_t lanes, Lead&& lead, Lane&& lane) {
  const std::size_t whole = lanes & ~std::size_t{7};
  if (whole == 0) {
    for_lanes(lanes, lead);
    return for_lanes(lanes, lane);
  }
  QBOND_SIMD for (std::size_t l = 0; l < 8; ++l) lead(l);
  for (std::size_t q0 = 0; q0 < whole; q0 += 8) QBOND_SIMD for (std::size_t l = 0; l < 8; ++l) {
      if (q0 + 8 + l < lanes) lead(q0 + 8 + l);
      lane(q0 + l);
    }
  if (whole != lanes) QBOND_SIMD for (std::size_t l = 0; l < 4; ++l) lane(whole + l);
}

// Local copies of a structure-of-arrays vector's pointers: held in registers through a loop (read
// through a reference, GCC reloads them every iteration and does not vectorise it).
template <std::size_t N>
struct Local {
  double* a[N];
  explicit Local(double* const (&from)[N]) {
    for (std::size_t e = 0; e < N; ++e) a[e] = from[e];
  }
  double* operator[](std::size_t e) const { return a[e]; }
};

// The distance between the kernels' per-quanta arrays (structure of arrays, n entries each, and
// padding past n for the affine runs' whole vectors): 3 cache lines more than a multiple of
// 4 KiB, so that the same quanta's entries of the arrays fall in different sets of the
// first-level cache (at a multiple of 4 KiB they would compete for one set's ways, and loads
// would wait on stores to other arrays).
inline std::size_t soa_stride(std::size_t n) { return (n + 511) / 512 * 512 + 24; }

// A kernel's per-quanta arrays carved from one buffer sized for `count` of them, soa_stride(n)
// apart: next() is the next array, take(a) points each of a's pointers at the next ones. The
// buffer starts on a cache line and soa_stride(n) is a multiple of 8, so every array does: a
// lattice's rows start at multiples of 8 quanta (40 at n = 40), and the kernels' 8-wide loads and
// stores at them take one line, not two (line_vector.hpp).
class SoaArrays {
 public:
  SoaArrays(LineVector<double>& buffer, std::size_t n, std::size_t count) : stride_(soa_stride(n)) {
    // Grown, never shrunk: a buffer that two kernels share (ImplicitSystem::arrays) keeps the
    // larger size, and resizing it back up would write every entry added. Its entries are
    // scratch, so a growing buffer lets go of the old ones first (a copy would hold both).
    if (buffer.size() < count * stride_) {
      LineVector<double>().swap(buffer);
      buffer.resize(count * stride_);
    }
    next_ = buffer.data();
  }
  double* next() { return (next_ += stride_) - stride_; }
  template <std::size_t N>
  void take(double* (&a)[N]) {
    for (double*& p : a) p = next();
  }
  std::size_t stride() const { return stride_; }

 private:
  std::size_t stride_;
  double* next_;
};

// An affine run's bond parameters from its first bond on: strength, rest length, damping.
struct RunParameters {
  const double *k, *L, *D;
  RunParameters(const State& state, const BondRun& run)
      : k(state.bonds.strength.data() + run.first),
        L(state.bonds.rest.data() + run.first),
        D(state.bonds.damping.data() + run.first) {}
};

// Whether every bond of an affine run's whole vectors has the linear law, and one damping model:
// 0 all axial, 1 all isotropic, −1 otherwise (the run then takes the per-bond path). Read 4
// one-byte enums at a time.
QBOND_VECTOR_INLINE int uniform_linear(const Bonds& bonds, const BondRun& run) {
  static_assert(sizeof(Law) == 1 && sizeof(DampingModel) == 1 && static_cast<int>(Law::linear) == 0 &&
                static_cast<int>(DampingModel::axial) == 0 && static_cast<int>(DampingModel::isotropic) == 1);
  const auto* law = reinterpret_cast<const unsigned char*>(bonds.law.data() + run.first);
  const auto* dm = reinterpret_cast<const unsigned char*>(bonds.damping_model.data() + run.first);
  std::uint32_t laws = 0, any_isotropic = 0, all_isotropic = ~std::uint32_t{0};
  for (std::size_t q = 0; q < affine_lanes(run); q += 4) {
    std::uint32_t l, d;
    std::memcpy(&l, law + q, 4);
    std::memcpy(&d, dm + q, 4);
    laws |= l;
    any_isotropic |= d;
    all_isotropic &= d;
  }
  if (laws != 0) return -1;
  if (any_isotropic == 0) return 0;
  return all_isotropic == 0x01010101 ? 1 : -1;
}

// Asks for the parameters of the bonds a few runs after an affine run's: the bond pass reads each
// parameter array in bursts of a run, interleaved with a dozen other streams, which the hardware
// prefetcher does not follow far enough ahead.
QBOND_VECTOR_INLINE void prefetch_parameters(const State& state, const BondRun& run) {
  constexpr std::size_t kAhead = 4 * kBondRun;
  const std::size_t b = run.first + kAhead;
  if (b + run.count > state.bonds.size()) return;
  for (std::size_t k = 0; k < run.count; k += 8) {  // a cache line of doubles
    __builtin_prefetch(state.bonds.strength.data() + b + k);
    __builtin_prefetch(state.bonds.rest.data() + b + k);
    __builtin_prefetch(state.bonds.damping.data() + b + k);
  }
}

// rows[e][base + k] += terms[e][k] for k in [k0, k1) and each of the N rows.
template <std::size_t N>
QBOND_VECTOR_INLINE void add_to_rows(double* const (&rows)[N], Index base, std::size_t k0, std::size_t k1,
                                     double* const (&terms)[N]) {
  double* r[N];
  for (std::size_t e = 0; e < N; ++e) r[e] = rows[e] + base;
  auto add = [&](std::size_t k) QBOND_LAMBDA_INLINE {
    QBOND_UNROLL(9) for (std::size_t e = 0; e < N; ++e) r[e][k] += terms[e][k];
  };
  if (k0 == 0 && k1 % 4 == 0) {  // whole vectors
    for_lanes(k1, add);
  } else {
    QBOND_SIMD for (std::size_t k = k0; k < k1; ++k) add(k);
  }
}

// One end of an affine run, whose first quanta is base: its rows the part owns += their bonds'
// terms, in whole vectors (the padded lanes add −0.0) when the part owns every row they reach.
template <std::size_t N>
QBOND_VECTOR_INLINE void add_affine_end(const BondRun& run, Index base, double* const (&rows)[N],
                                        double* const (&terms)[N]) {
  if (base >= run.lo && base + affine_lanes(run) <= run.hi) {
    add_to_rows(rows, base, 0, affine_lanes(run), terms);
  } else {
    const Index k0 = run.lo > base ? std::min(run.lo - base, run.count) : 0;
    const Index k1 = run.hi > base ? std::min(run.hi - base, run.count) : 0;
    add_to_rows(rows, base, k0, k1, terms);
  }
}

// Adds an affine run's terms (ti on bond_i's rows, tj on bond_j's) to the rows its part owns, the
// end with the higher quanta numbers first: a row q = i0 + k = j0 + k' (j0 > i0) is bond_j of
// bond k' = k − (j0 − i0) before it is bond_i of bond k, so it receives them in bond order, as a
// bond-by-bond pass would and whatever the run's pieces: the same bits for any thread count.
// The kernels' vector loops compute every lane alike (a select per term and lane cost a fifth of
// their instructions); the lanes past the run's bonds are set to −0.0 here, which added to a row
// leave its bits as they are.
template <std::size_t N>
QBOND_VECTOR_INLINE void add_affine_run(const BondRun& run, double* const (&rows)[N], double* const (&ti)[N],
                                        double* const (&tj)[N]) {
  for (Index q = run.count; q < affine_lanes(run); ++q)
    for (std::size_t e = 0; e < N; ++e) ti[e][q] = tj[e][q] = -0.0;
  if (run.j0 > run.i0) {
    add_affine_end(run, run.j0, rows, tj);
    add_affine_end(run, run.i0, rows, ti);
  } else {
    add_affine_end(run, run.i0, rows, ti);
    add_affine_end(run, run.j0, rows, tj);
  }
}

// r = |d| and 1/r, 0 for r = 0 (a zero-length bond has no direction). The division's operand is
// selected first and the division done unconditionally, so that a loop calling this has no branch.
struct Length {
  double r, inv_r;
};
QBOND_VECTOR_INLINE Length length(double dx, double dy, double dz) {
  const double r = std::sqrt(dx * dx + dy * dy + dz * dz);
  const double inv_any = 1.0 / (r > 0 ? r : 1.0);
  return {r, r > 0 ? inv_any : 0.0};
}

// The lengths r = |x_j − x_i| of an affine run's bonds and 1/r (0 for r = 0), lane q's by
// operator()(q), from positions as structure of arrays: a vector ahead, in the loop that forms the
// bonds' terms (add_affine_terms' `lead`). Inline at the head of that loop's chain of dependent
// operations, the square root and the division (~33 cycles of latency on Zen 3, ~40 on the Xeon)
// would outlast the out-of-order window, ~1.5 iterations of that loop; in a loop of their own
// before it the divider and the other units would take turns instead of overlapping.
struct AffineLengths {
  const double *xi[3], *xj[3];
  double *r, *inv_r;
  AffineLengths(const BondRun& run, const double* const (&x)[3], double* r, double* inv_r)
      : r(r), inv_r(inv_r) {
    for (int c = 0; c < 3; ++c) {
      xi[c] = x[c] + run.i0;
      xj[c] = x[c] + run.j0;
    }
  }
  QBOND_VECTOR_INLINE void operator()(std::size_t q) const {
    const Length l = length(xj[0][q] - xi[0][q], xj[1][q] - xi[1][q], xj[2][q] - xi[2][q]);
    r[q] = l.r;
    inv_r[q] = l.inv_r;
  }
};

// No lead (add_affine_terms): the terms need nothing computed ahead of them.
struct NoLead {
  QBOND_VECTOR_INLINE void operator()(std::size_t) const {}
};

// How many quanta apart an affine run's ends are.
inline Index ends_apart(const BondRun& run) { return run.j0 > run.i0 ? run.j0 - run.i0 : run.i0 - run.j0; }

// Whether an affine run can add its terms to the rows straight from the loop that forms them
// (add_affine_fused): its part owns every row the run's lanes reach, and its ends are at least
// 4 quanta apart, so that a vector of 4 consecutive bonds reaches 8 distinct rows.
inline bool fusable(const BondRun& run) {
  const Index lanes = affine_lanes(run);
  return ends_apart(run) >= 4 && std::min(run.i0, run.j0) >= run.lo &&
         std::max(run.i0, run.j0) + lanes <= run.hi;
}

// For a fusable run: terms(q, ti, tj) fills bond q's terms on bond_i's rows (ti) and bond_j's (tj),
// and each is added to its row in the same vector loop, with no term arrays between. A row that
// is both bond_j of bond k' and bond_i of bond k > k' (or the reverse: |j0 − i0| bonds apart)
// gets them from loop iterations in that order, of which run together at most 8 when the ends are
// 8 or more apart, else 4: in bond order, the same sums as add_affine_run's. The lanes past the
// run's bonds add −0.0. lead(q) prepares what terms(q, ...) reads (AffineLengths): for a vector of
// 8 lanes one iteration ahead of it, so that the two overlap (lead's square roots and divisions
// use the divider, terms' arithmetic the other units), else for every lane first.
template <std::size_t N, class Terms, class Lead = NoLead>
QBOND_VECTOR_INLINE void add_affine_fused(const BondRun& run, double* const (&rows)[N], Terms&& terms,
                                          Lead&& lead = {}) {
  const std::size_t i0 = run.i0, j0 = run.j0, count = run.count;
  const Local<N> r(rows);
  auto add = [&]<bool kTail>(std::size_t q) QBOND_LAMBDA_INLINE {
    double ti[N], tj[N];
    terms(q, ti, tj);
    if constexpr (kTail) {
      QBOND_UNROLL(9) for (std::size_t e = 0; e < N; ++e) {
        ti[e] = q < count ? ti[e] : -0.0;
        tj[e] = q < count ? tj[e] : -0.0;
      }
    }
    QBOND_UNROLL(9) for (std::size_t e = 0; e < N; ++e) {
      r[e][i0 + q] += ti[e];
      r[e][j0 + q] += tj[e];
    }
  };
  const bool wide = ends_apart(run) >= 8;
  const std::size_t whole = wide ? count & ~std::size_t{7} : 0, lanes = affine_lanes(run);
  if (wide && lanes >= 8) {
    QBOND_SIMD for (std::size_t l = 0; l < 8; ++l) lead(l);  // kVectorLoop
  } else {
    for_lanes(lanes, lead);
  }
  QBOND_SIMD_SAFELEN(8) for (std::size_t q = 0; q < whole; ++q) {  // kVectorLoop
    if (q + 8 < lanes) lead(q + 8);
    add.template operator()<false>(q);
  }
  if (wide &&
      lanes - whole == 8) {  // one vector of 8 rather than two of 4 (a lattice row's 39 bonds: 32 + 8)
    QBOND_SIMD for (std::size_t l = 0; l < 8; ++l) add.template operator()<true>(whole + l);  // kVectorLoop
    return;
  }
  for (std::size_t q0 = whole; q0 < lanes; q0 += 4)
    QBOND_SIMD for (std::size_t l = 0; l < 4; ++l) add.template operator()<true>(q0 + l);  // kVectorLoop
}

// Adds an affine run's terms (terms(q, ti, tj), as add_affine_fused takes them, after lead(q)) to
// the rows its part owns: from the loop that forms them when the run is fusable, else through the
// term arrays ti and tj (kBondRun entries each) and add_affine_run.
template <std::size_t N, class Terms, class Lead = NoLead>
QBOND_VECTOR_INLINE void add_affine_terms(const BondRun& run, double* const (&rows)[N], Terms&& terms,
                                          double* const (&ti)[N], double* const (&tj)[N], Lead&& lead = {}) {
  if (fusable(run)) return add_affine_fused(run, rows, terms, lead);
  for_lanes_led(affine_lanes(run), lead, [&](std::size_t q) QBOND_LAMBDA_INLINE {  // kVectorLoop
    double a[N], b[N];
    terms(q, a, b);
    QBOND_UNROLL(9) for (std::size_t e = 0; e < N; ++e) {
      ti[e][q] = a[e];
      tj[e][q] = b[e];
    }
  });
  add_affine_run(run, rows, ti, tj);
}

}  // namespace qbond
