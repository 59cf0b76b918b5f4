#include "ledger/energy_sums.hpp"

#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstring>
#include <functional>

#include "core/parallel.hpp"
#include "core/simd.hpp"

namespace qbond {
namespace {

constexpr std::size_t kLanes = 8;

// How many of bonds b, b + 1, ..., b + 7 in a row are alive and continue bond b's ends (bond b + k
// joins bond_i[b] + k and bond_j[b] + k): their ends' data are then contiguous, and their terms
// one vector loop.
QBOND_VECTOR_INLINE int affine_prefix(const State& s, std::size_t b) {
  const Index* bi = s.bonds.i.data() + b;
  const Index* bj = s.bonds.j.data() + b;
  const std::uint8_t* alive = s.bonds.alive.data() + b;
  // Bond b + 1 does not continue bond b (bonds listed by quanta, as a small body's): at most one,
  // told before the eight lanes' compares.
  if (!((alive[1] != 0) & (bi[1] == bi[0] + 1) & (bj[1] == bj[0] + 1))) return alive[0] != 0;
  unsigned good = 0;  // bit k: bond b + k continues (compares, no branch per bond)
  for (Index k = 0; k < kLanes; ++k)
    good |= static_cast<unsigned>((alive[k] != 0) & (bi[k] == bi[0] + k) & (bj[k] == bj[0] + k)) << k;
  return std::countr_one(good);
}

// Whether affine_prefix(s, b) is all eight, as one vector loop (the test before every whole
// block: the per-lane bits above cost as much as a fifth of the block's terms).
QBOND_VECTOR_INLINE bool affine_block(const State& s, std::size_t b) {
  const Index* bi = s.bonds.i.data() + b;
  const Index* bj = s.bonds.j.data() + b;
  const std::uint8_t* alive = s.bonds.alive.data() + b;
  const Index i0 = bi[0], j0 = bj[0];
  Index off = 0;  // 0 iff bi[k] == bi[0] + k and bj[k] == bj[0] + k (Index arithmetic, as above)
  QBOND_SIMD_OR(off) for (Index k = 0; k < kLanes; ++k) off |= (bi[k] - i0 - k) | (bj[k] - j0 - k);
  // Whether one of the eight one-byte flags is 0: the classic test for a zero byte in a word.
  std::uint64_t flags;
  std::memcpy(&flags, alive, 8);
  const std::uint64_t dead = (flags - 0x0101010101010101) & ~flags & 0x8080808080808080;
  return off == 0 && dead == 0;
}

// Whether the first `count` (at most eight) of the eight one-byte entries of `a` from b equal a[b]:
// one 64-bit compare (entry l in byte l: little-endian).
template <class T>
QBOND_VECTOR_INLINE bool uniform_prefix(const T* a, std::size_t b, std::size_t count) {
  static_assert(sizeof(T) == 1 && std::endian::native == std::endian::little);
  std::uint64_t eight;
  std::memcpy(&eight, a + b, 8);
  const std::uint64_t first = static_cast<std::uint8_t>(a[b]);
  const std::uint64_t mask = count >= kLanes ? ~std::uint64_t{0} : (std::uint64_t{1} << (8 * count)) - 1;
  return ((eight ^ (first * 0x0101010101010101)) & mask) == 0;
}

// N sums over the alive bonds of [b0, b1): affine blocks of eight, and of two to seven where no
// whole one starts, that uniform(b, count) accepts, a block's N terms of bond b + l, which
// block_terms<L>(i, j, b, t) writes to t[·][l] for its first L lanes (bond b + l joins i + l and
// j + l; vector loops), added to lanes[·][l] for l < count (the other lanes add −0.0, or, past
// the first four for a block of at most four, nothing: the same sums, for half the arithmetic in
// a small body's rows of four); every other bond into one more partial per sum by
// bond_term(i, j, b) (its N terms); the lanes added in order, that partial last. Which bonds go
// where depends on the bonds only, never on the thread.
template <std::size_t N>
using Sums = std::array<double, N>;
template <std::size_t N, class BlockTerms, class BondTerm, class Uniform>
QBOND_VECTOR_INLINE Sums<N> chunk_sums(const State& s, std::size_t b0, std::size_t b1,
                                       BlockTerms&& block_terms, BondTerm&& bond_term, Uniform&& uniform) {
  const std::size_t n = s.x.size();
  double lanes[N][kLanes] = {};
  auto lanes_of = [&]<std::size_t L>(std::size_t i, std::size_t j, std::size_t b, std::size_t count)
                      QBOND_LAMBDA_INLINE {
    // The terms first, then their sums: GCC vectorises no loop that adds into two lane arrays as
    // it computes.
    double t[N][kLanes];
    block_terms.template operator()<L>(i, j, b, t);
    for (std::size_t k = 0; k < N; ++k)
      QBOND_SIMD for (std::size_t l = 0; l < L; ++l) lanes[k][l] += l < count ? t[k][l] : -0.0;
  };
  auto block = [&](std::size_t i, std::size_t j, std::size_t b, std::size_t count) QBOND_LAMBDA_INLINE {
    if (count > kLanes / 2)
      lanes_of.template operator()<kLanes>(i, j, b, count);
    else
      lanes_of.template operator()<kLanes / 2>(i, j, b, count);
  };
  Sums<N> others{};
  std::size_t b = b0;
  while (b < b1) {
    // The whole blocks from b first, then their loop: no branch between one block and the next.
    std::size_t e = b;
    while (e + kLanes <= b1 && affine_block(s, e) && uniform(e, kLanes)) e += kLanes;
    for (std::size_t q = b; q < e; q += kLanes) block(s.bonds.i[q], s.bonds.j[q], q, kLanes);
    if (e >= b1) break;
    // A shorter block at e (its vector loop reads all eight lanes' ends and parameters, which
    // must exist), else bond e alone.
    const Index i = s.bonds.i[e], j = s.bonds.j[e];
    const int count = e + kLanes <= b1 && i + kLanes <= n && j + kLanes <= n ? affine_prefix(s, e) : 0;
    if (count >= 2 && uniform(e, count)) {
      block(i, j, e, count);
      b = e + count;
    } else {
      if (s.bonds.alive[e]) {
        const Sums<N> t = bond_term(i, j, e);
        for (std::size_t k = 0; k < N; ++k) others[k] += t[k];
      }
      b = e + 1;
    }
  }
  Sums<N> sums{};
  for (std::size_t k = 0; k < N; ++k) {
    for (double l : lanes[k]) sums[k] += l;
    sums[k] += others[k];
  }
  return sums;
}

// |x_j − x_i| for positions stored as consecutive triples.
QBOND_VECTOR_INLINE double length(const double* x, std::size_t i, std::size_t j) {
  double r2 = 0;
  QBOND_UNROLL(3)
  for (std::size_t c = 0; c < 3; ++c) {
    const double d = x[3 * j + c] - x[3 * i + c];
    r2 += d * d;
  }
  return std::sqrt(r2);
}

// U_b of a linear bond of length r (evaluate_law's, Eq. 2), written out so that a block of them
// vectorises.
QBOND_VECTOR_INLINE double linear_energy(double k, double r, double rest) {
  const double e = r - rest;
  return 0.5 * k * e * e;
}

QBOND_VECTOR_CLONES double energy_chunk(const Model& m, const State& s, std::size_t b0, std::size_t b1) {
  const double* x = s.x.data()->data();
  const double* rest = s.bonds.rest.data();
  const double* k = s.bonds.strength.data();
  const Law* law = s.bonds.law.data();
  auto block = [=]<std::size_t L>(std::size_t i, std::size_t j, std::size_t b, double(&t)[1][kLanes])
                   QBOND_LAMBDA_INLINE {
    QBOND_SIMD for (std::size_t l = 0; l < L; ++l)
      t[0][l] = linear_energy(k[b + l], length(x, i + l, j + l), rest[b + l]);
  };
  auto any_law = [&](std::size_t i, std::size_t j, std::size_t b) {
    return Sums<1>{s.bonds.law_at(m.shapes, b, length(x, i, j), rest[b]).U};
  };
  auto all_linear = [=](std::size_t b, std::size_t count) QBOND_LAMBDA_INLINE {
    return law[b] == Law::linear && uniform_prefix(law, b, count);
  };
  return chunk_sums<1>(s, b0, b1, block, any_law, all_linear)[0];
}

// U_b(r1) − U_b(r0) of a linear bond, as ½ k (r1 − r0)(r1 + r0 − 2 L): no cancellation between
// two large energies when the bond barely moves.
QBOND_VECTOR_INLINE double linear_energy_change(double k, double r0, double r1, double rest) {
  return 0.5 * k * (r1 - r0) * (r1 + r0 - 2 * rest);
}

// |(x_j + Δx_j) − (x_i + Δx_i)| for positions and displacements stored as consecutive triples.
QBOND_VECTOR_INLINE double moved_length(const double* x, const double* dx, std::size_t i, std::size_t j) {
  double r2 = 0;
  QBOND_UNROLL(3)
  for (std::size_t c = 0; c < 3; ++c) {
    const double d = (x[3 * j + c] - x[3 * i + c]) + (dx[3 * j + c] - dx[3 * i + c]);
    r2 += d * d;
  }
  return std::sqrt(r2);
}

// Σ U_b(r1) − U_b(r0) and Σ U_b(r0) + U_b(r1) over bonds [b0, b1) (bond_energy_change).
QBOND_VECTOR_CLONES Sums<2> energy_change_chunk(const Model& m, const State& s, const double* dx, std::size_t b0,
                                               std::size_t b1) {
  const double* x = s.x.data()->data();
  const double* rest = s.bonds.rest.data();
  const double* k = s.bonds.strength.data();
  const Law* law = s.bonds.law.data();
  auto block = [=]<std::size_t L>(std::size_t i, std::size_t j, std::size_t b, double(&t)[2][kLanes])
                   QBOND_LAMBDA_INLINE {
    QBOND_SIMD for (std::size_t l = 0; l < L; ++l) {
      const double r0 = length(x, i + l, j + l), r1 = moved_length(x, dx, i + l, j + l);
      t[0][l] = linear_energy_change(k[b + l], r0, r1, rest[b + l]);
      t[1][l] = linear_energy(k[b + l], r0, rest[b + l]) + linear_energy(k[b + l], r1, rest[b + l]);
    }
  };
  auto any_law = [&](std::size_t i, std::size_t j, std::size_t b) {
    const double r0 = length(x, i, j), r1 = moved_length(x, dx, i, j);
    if (law[b] == Law::linear)
      return Sums<2>{linear_energy_change(k[b], r0, r1, rest[b]),
                     linear_energy(k[b], r0, rest[b]) + linear_energy(k[b], r1, rest[b])};
    const double u0 = s.bonds.law_at(m.shapes, b, r0, rest[b]).U, u1 = s.bonds.law_at(m.shapes, b, r1, rest[b]).U;
    return Sums<2>{u1 - u0, std::abs(u0) + std::abs(u1)};
  };
  auto all_linear = [=](std::size_t b, std::size_t count) QBOND_LAMBDA_INLINE {
    return law[b] == Law::linear && uniform_prefix(law, b, count);
  };
  return chunk_sums<2>(s, b0, b1, block, any_law, all_linear);
}

// How the step's dampers were evaluated: at the start's bond direction (φ = 0) or along d + φ Δd,
// and at the start's velocities (θ = 0), the end's (θ = 1) or v + θ Δv. The common cases read
// fewer arrays and do fewer operations a bond.
enum class DamperPoint { start_end, start_start, start_any, any_any };

// A bond's share of the linearised backward-Euler step's loss, exactly: Δdᵀ K_c Δd + T₀ u·Δd −
// (U(r₁) − U(r₀)), from the step's clamped stiffness block K_c (clamped_stiffness of the bond's
// axial and transverse coefficients at d₀), its tension T₀ and direction u at d₀, u·Δd, (u·Δd)²,
// |Δd|² and the energy change dU. The solve's forces are f₀ − K_c Δd, linear in Δd; this is the
// energy they leave out against the bond's own law: ½ Δdᵀ K Δd for a quadratic energy with nothing
// clamped, more where the bond turns or stretches far within the step.
[[gnu::always_inline]] inline double step_loss(double axial, double transverse, double tension, double along,
                                               double along2, double delta2, double dU) {
  const StiffnessCoefficients c = clamped_stiffness(axial, transverse);
  return c.axial * along2 + c.transverse * (delta2 - along2) + tension * along - dU;
}

// The dampers' work and the bonds' energy at the applied positions (bond_step_sums) over bonds
// [b0, b1), the dampers evaluated at kPoint; with kLoss (backward Euler: kPoint start_end) also
// step_loss, Δd = d₁ − d₀.
template <DamperPoint kPoint, bool kLoss = false, std::size_t N = kLoss ? 3 : 2>
QBOND_VECTOR_INLINE Sums<N> step_chunk_at(const Model& m, const State& s, const double* x1, const double* v1,
                                          double h, double theta, double phi, std::size_t b0,
                                          std::size_t b1) {
  constexpr bool kStartBond = kPoint != DamperPoint::any_any;
  const double* x = s.x.data()->data();
  const double* v = s.v.data()->data();
  const double* D = s.bonds.damping.data();
  const double* rest = s.bonds.rest.data();
  const double* k = s.bonds.strength.data();
  const Law* law = s.bonds.law.data();
  const DampingModel* model = s.bonds.damping_model.data();
  static_assert(!kLoss || kPoint == DamperPoint::start_end);
  // The damper's loss and the end length |x1_j − x1_i| from the bond d at which the damper is
  // charged, the relative velocity w and the end bond d₁; with kLoss, the start's length r0,
  // u·Δd, (u·Δd)² and |Δd|² (u = d / r0).
  struct Term {
    double loss, r1, r0 = 0, along = 0, along2 = 0, delta2 = 0;
  };
  auto term = [=](const double (&d)[3], const double (&w)[3], const double (&d1)[3], double Db,
                  bool axial) QBOND_LAMBDA_INLINE {
    double d2 = 0, wd = 0, w2 = 0, r2 = 0;
    QBOND_UNROLL(3)
    for (std::size_t c = 0; c < 3; ++c) {
      d2 += d[c] * d[c];
      wd += w[c] * d[c];
      w2 += w[c] * w[c];
      r2 += d1[c] * d1[c];
    }
    // Both losses computed, then one selected (no branch in a lane), every lane's D loaded (no
    // masked load); a zero-length bond's NaN is not selected.
    const double along = wd * wd / d2;
    const double loss = h * Db * (axial ? along : w2);
    Term t{d2 > 0 ? loss : 0.0, std::sqrt(r2)};
    if constexpr (kLoss) {
      double dd = 0, delta2 = 0;
      QBOND_UNROLL(3)
      for (std::size_t c = 0; c < 3; ++c) {
        const double e = d1[c] - d[c];
        dd += d[c] * e;
        delta2 += e * e;
      }
      // A zero-length bond (r0 = 0) has no stiffness block: the callers select 0 for it.
      t.r0 = std::sqrt(d2);
      t.along = dd / t.r0;
      t.along2 = t.along * t.along;
      t.delta2 = delta2;
    }
    return t;
  };
  // d, w and d₁ of the bond joining the triples at a and e (element offsets 3 i, 3 j), or of the
  // eight bonds of a block from them (k: element k of the eight ends' consecutive triples).
  auto differences = [=](std::size_t a, std::size_t e, double& d, double& w, double& d1) QBOND_LAMBDA_INLINE {
    const double d0 = x[e] - x[a];
    d1 = x1[e] - x1[a];
    d = kStartBond ? d0 : d0 + phi * (d1 - d0);
    if constexpr (kPoint == DamperPoint::start_end) {
      w = v1[e] - v1[a];
    } else if constexpr (kPoint == DamperPoint::start_start) {
      w = v[e] - v[a];
    } else {
      const double w0 = v[e] - v[a];
      w = w0 + theta * ((v1[e] - v1[a]) - w0);
    }
  };
  auto block = [=]<std::size_t L>(std::size_t i, std::size_t j, std::size_t b, double(&t)[N][kLanes])
                   QBOND_LAMBDA_INLINE {
    // The ends' triples are contiguous: the differences are formed on them as stored, element by
    // element in contiguous vectors, and only d, w and d₁ are then split into their components
    // (split first, the eight arrays' stride-3 shuffles would be half the loop's instructions).
    constexpr std::size_t K = 3 * L;
    double d[K], w[K], d1[K];
    QBOND_SIMD for (std::size_t k = 0; k < K; ++k) differences(3 * i + k, 3 * j + k, d[k], w[k], d1[k]);
    const bool axial = model[b] == DampingModel::axial;  // the block's first bond's (uniform)
    QBOND_SIMD for (std::size_t l = 0; l < L; ++l) {
      const double dl[3] = {d[3 * l], d[3 * l + 1], d[3 * l + 2]};
      const double wl[3] = {w[3 * l], w[3 * l + 1], w[3 * l + 2]};
      const double d1l[3] = {d1[3 * l], d1[3 * l + 1], d1[3 * l + 2]};
      const Term bond = term(dl, wl, d1l, D[b + l], axial);
      t[0][l] = bond.loss;
      t[1][l] = linear_energy(k[b + l], bond.r1, rest[b + l]);
      // The linear law's T = k (r0 − L), T' = k; a zero-length bond's NaN is not selected.
      if constexpr (kLoss) {
        const double tension = k[b + l] * (bond.r0 - rest[b + l]);
        t[2][l] = bond.r0 > 0 ? step_loss(k[b + l], tension / bond.r0, tension, bond.along, bond.along2, bond.delta2,
                                          linear_energy_change(k[b + l], bond.r0, bond.r1, rest[b + l]))
                              : 0.0;
      }
    }
  };
  auto bond = [&](std::size_t i, std::size_t j, std::size_t b) {
    double d[3], w[3], d1[3];
    for (std::size_t c = 0; c < 3; ++c) differences(3 * i + c, 3 * j + c, d[c], w[c], d1[c]);
    const Term t = term(d, w, d1, D[b], model[b] == DampingModel::axial);
    const double energy = s.bonds.law_at(m.shapes, b, t.r1, rest[b]).U;
    if constexpr (kLoss) {
      const LawValue lv = t.r0 > 0 ? s.bonds.law_at(m.shapes, b, t.r0, rest[b]) : LawValue{};
      return Sums<N>{t.loss, energy,
                     t.r0 > 0 ? step_loss(lv.dT, lv.T / t.r0, lv.T, t.along, t.along2, t.delta2, energy - lv.U) : 0.0};
    } else {
      return Sums<N>{t.loss, energy};
    }
  };
  auto uniform = [=](std::size_t b, std::size_t count) QBOND_LAMBDA_INLINE {
    return law[b] == Law::linear && uniform_prefix(law, b, count) && uniform_prefix(model, b, count);
  };
  return chunk_sums<N>(s, b0, b1, block, bond, uniform);
}

QBOND_VECTOR_CLONES Sums<3> step_chunk(const Model& m, const State& s, const double* x1, const double* v1,
                                       double h, double theta, double phi, bool loss, std::size_t b0,
                                       std::size_t b1) {
  using enum DamperPoint;
  if (loss) return step_chunk_at<start_end, true>(m, s, x1, v1, h, theta, phi, b0, b1);
  auto two = [](const Sums<2>& t) { return Sums<3>{t[0], t[1], 0.0}; };
  if (phi != 0) return two(step_chunk_at<any_any>(m, s, x1, v1, h, theta, phi, b0, b1));
  if (theta == 1) return two(step_chunk_at<start_end>(m, s, x1, v1, h, theta, phi, b0, b1));
  if (theta == 0) return two(step_chunk_at<start_start>(m, s, x1, v1, h, theta, phi, b0, b1));
  return two(step_chunk_at<start_any>(m, s, x1, v1, h, theta, phi, b0, b1));
}

}  // namespace

double bond_energy_sum(const Model& m, const State& s, int threads) {
  return reduce_chunks(
      s.bonds.size(), bond_pass_threads(m.num_quanta(), threads), 0.0,
      [&](std::size_t b0, std::size_t b1) { return energy_chunk(m, s, b0, b1); }, std::plus<>{});
}

BondEnergyChange bond_energy_change(const Model& m, const State& s, std::span<const Vec3> dx, int threads) {
  assert(dx.size() == m.num_quanta());
  auto chunk = [&](std::size_t b0, std::size_t b1) { return energy_change_chunk(m, s, dx.data()->data(), b0, b1); };
  const Sums<2> sums = reduce_chunks(s.bonds.size(), bond_pass_threads(m.num_quanta(), threads), Sums<2>{},
                                     chunk, [](const Sums<2>& p, const Sums<2>& q) {
                                       return Sums<2>{p[0] + q[0], p[1] + q[1]};
                                     });
  return {sums[0], sums[1]};
}

BondStepSums bond_step_sums(const Model& m, const State& s, const AppliedState& a, double h, double theta,
                            double phi, bool backward_euler, int threads) {
  assert(a.x.size() == m.num_quanta() && a.v.size() == m.num_quanta());
  assert(!backward_euler || (theta == 1 && phi == 0));
  auto chunk = [&](std::size_t b0, std::size_t b1) {  // a chunk has bonds, so quanta: the arrays have data
    return step_chunk(m, s, a.x.data()->data(), a.v.data()->data(), h, theta, phi, backward_euler, b0, b1);
  };
  const Sums<3> sums = reduce_chunks(s.bonds.size(), bond_pass_threads(m.num_quanta(), threads), Sums<3>{},
                                     chunk, [](const Sums<3>& p, const Sums<3>& q) {
                                       return Sums<3>{p[0] + q[0], p[1] + q[1], p[2] + q[2]};
                                     });
  return {sums[0], sums[1], sums[2]};
}

}  // namespace qbond
