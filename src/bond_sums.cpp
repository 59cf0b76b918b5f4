#include "bond_sums.hpp"

#include <bit>
#include <cmath>
#include <functional>

#include "parallel.hpp"
#include "simd.hpp"

namespace qbond {
namespace {

constexpr std::size_t kLanes = 8;

// How many of bonds b, b + 1, ..., b + 7 in a row are alive and continue bond b's ends (bond b + k
// joins bond_i[b] + k and bond_j[b] + k): their ends' data are then contiguous, and their terms
// one vector loop.
QBOND_VECTOR_INLINE int affine_prefix(const Model& m, const State& s, std::size_t b) {
  const Index* bi = m.bond_i.data() + b;
  const Index* bj = m.bond_j.data() + b;
  const std::uint8_t* alive = s.alive.data() + b;
  unsigned good = 0;  // bit k: bond b + k continues (compares, no branch per bond)
  for (Index k = 0; k < kLanes; ++k)
    good |= static_cast<unsigned>((alive[k] != 0) & (bi[k] == bi[0] + k) & (bj[k] == bj[0] + k)) << k;
  return std::countr_one(good);
}

// Whether the first `count` of the eight entries of `a` from b equal a[b].
template <class T>
QBOND_VECTOR_INLINE bool uniform_prefix(const T* a, std::size_t b, std::size_t count) {
  unsigned bad = 0;
  for (std::size_t l = 0; l < kLanes; ++l)
    bad |= (l < count) & (static_cast<unsigned>(a[b + l]) != static_cast<unsigned>(a[b]));
  return bad == 0;
}

// Σ over the alive bonds of [b0, b1): affine blocks of eight, and of two to seven where no whole
// one starts, that uniform(b, count) accepts, in one vector loop a block adding
// lane_term(i + l, j + l, b + l, b) (b the block's first bond) to lanes[l] for l < count (the
// other lanes are computed and add −0.0); every other bond into one more partial by
// bond_term(i, j, b); the lanes added in order, that partial last. Which bonds go where depends on
// the bonds only, never on the thread.
template <class LaneTerm, class BondTerm, class Uniform>
QBOND_VECTOR_INLINE double chunk_sum(const Model& m, const State& s, std::size_t b0, std::size_t b1,
                                     LaneTerm&& lane_term, BondTerm&& bond_term, Uniform&& uniform) {
  const std::size_t n = s.x.size();
  double lanes[kLanes] = {};
  auto block = [&](std::size_t i, std::size_t j, std::size_t b, std::size_t count) QBOND_LAMBDA_INLINE {
    QBOND_SIMD
    for (std::size_t l = 0; l < kLanes; ++l) {
      const double t = lane_term(i + l, j + l, b + l, b);
      lanes[l] += l < count ? t : -0.0;
    }
  };
  double others = 0;
  std::size_t b = b0;
  while (b < b1) {
    // The whole blocks from b first, then their loop: no branch between one block and the next.
    std::size_t e = b;
    while (e + kLanes <= b1 && affine_prefix(m, s, e) == kLanes && uniform(e, kLanes)) e += kLanes;
    for (std::size_t q = b; q < e; q += kLanes) block(m.bond_i[q], m.bond_j[q], q, kLanes);
    if (e >= b1) break;
    // A shorter block at e (its vector loop reads all eight lanes' ends and parameters, which
    // must exist), else bond e alone.
    const Index i = m.bond_i[e], j = m.bond_j[e];
    const int count = e + kLanes <= b1 && i + kLanes <= n && j + kLanes <= n ? affine_prefix(m, s, e) : 0;
    if (count >= 2 && uniform(e, count)) {
      block(i, j, e, count);
      b = e + count;
    } else {
      if (s.alive[e]) others += bond_term(i, j, e);
      b = e + 1;
    }
  }
  double sum = 0;
  for (double l : lanes) sum += l;
  return sum + others;
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

QBOND_VECTOR_CLONES double energy_chunk(const Model& m, const State& s, std::size_t b0, std::size_t b1) {
  const double* x = s.x.data()->data();
  const double* rest = s.rest.data();
  const double* k = m.stiffness.data();
  const Law* law = m.law.data();
  // A linear bond's energy written out (evaluate_law's, Eq. 2) so that a block of them vectorises.
  auto linear = [=](std::size_t i, std::size_t j, std::size_t b) QBOND_LAMBDA_INLINE {
    const double e = length(x, i, j) - rest[b];
    return 0.5 * k[b] * e * e;
  };
  auto lane = [=](std::size_t i, std::size_t j, std::size_t b, std::size_t) QBOND_LAMBDA_INLINE {
    return linear(i, j, b);
  };
  auto any_law = [&](std::size_t i, std::size_t j, std::size_t b) {
    return law[b] == Law::linear ? linear(i, j, b) : m.law_at(b, length(x, i, j), rest[b]).U;
  };
  auto all_linear = [=](std::size_t b, std::size_t count) QBOND_LAMBDA_INLINE {
    return law[b] == Law::linear && uniform_prefix(law, b, count);
  };
  return chunk_sum(m, s, b0, b1, lane, any_law, all_linear);
}

QBOND_VECTOR_CLONES double damping_chunk(const Model& m, const State& s, const Projection& p, double h, double theta,
                                         double phi, std::size_t b0, std::size_t b1) {
  const double* x = s.x.data()->data();
  const double* v = s.v.data()->data();
  const double* dx = p.dx.data()->data();
  const double* dv = p.dv.data()->data();
  const double* D = m.damping.data();
  const DampingModel* model = m.damping_model.data();
  // The damping model is an argument: a block reads its first bond's only, so that its loop has
  // no byte load per lane (which would make GCC vectorise it in 64 lanes, more than it has).
  auto term = [=](std::size_t i, std::size_t j, std::size_t b, bool axial) QBOND_LAMBDA_INLINE {
    double d2 = 0, wd = 0, w2 = 0;
    QBOND_UNROLL(3)
    for (std::size_t c = 0; c < 3; ++c) {
      const std::size_t a = 3 * i + c, e = 3 * j + c;
      const double d = x[e] - x[a] + phi * (dx[e] - dx[a]);
      const double w = (v[e] + theta * dv[e]) - (v[a] + theta * dv[a]);
      d2 += d * d;
      wd += w * d;
      w2 += w * w;
    }
    const double loss = h * D[b] * (axial ? wd * wd / d2 : w2);  // every lane's D loaded: no masked load
    return d2 > 0 ? loss : 0.0;
  };
  auto lane = [=](std::size_t i, std::size_t j, std::size_t b, std::size_t first) QBOND_LAMBDA_INLINE {
    return term(i, j, b, model[first] == DampingModel::axial);
  };
  auto bond = [=](std::size_t i, std::size_t j, std::size_t b) { return term(i, j, b, model[b] == DampingModel::axial); };
  auto one_model = [=](std::size_t b, std::size_t count) QBOND_LAMBDA_INLINE { return uniform_prefix(model, b, count); };
  return chunk_sum(m, s, b0, b1, lane, bond, one_model);
}

}  // namespace

double bond_energy_sum(const Model& m, const State& s, int threads) {
  return reduce_chunks(
      m.num_bonds(), threads, 0.0, [&](std::size_t b0, std::size_t b1) { return energy_chunk(m, s, b0, b1); },
      std::plus<>{});
}

double damping_work_sum(const Model& m, const State& s, const Projection& p, double h, double theta, double phi,
                        int threads) {
  return reduce_chunks(
      m.num_bonds(), threads, 0.0,
      [&](std::size_t b0, std::size_t b1) { return damping_chunk(m, s, p, h, theta, phi, b0, b1); }, std::plus<>{});
}

}  // namespace qbond
