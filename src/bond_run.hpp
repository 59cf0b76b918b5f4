#pragma once
// Vectorised bond kernels: a bond pass (bond_partition.hpp) taken in runs of kBondRun bonds. A
// run's per-bond quantities are computed first in structure-of-arrays loops without branches,
// which the compiler vectorises across bonds (the ends' positions and velocities gathered), in a
// function compiled for several instruction sets (simd.hpp); then the run's ends are updated one
// bond at a time, in bond order, so that each quanta's sum keeps its order for any thread count.
#include <cmath>

#include "bond_partition.hpp"
#include "qbond/laws.hpp"
#include "simd.hpp"

namespace qbond {

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

// Fills t for the run: its bonds, parameters, unit vectors, u·v at both ends and the laws, at
// positions x and velocities v (Vec3 arrays as doubles). A zero-length bond has no direction: its
// u, tension, slope and damping are 0 (the bond then does nothing, as in laws.hpp).
QBOND_VECTOR_INLINE void measure_run(const Model& model, const State& state, const double* x, const double* v,
                                     const BondRun& run, RunBonds& t) {
  const Index n = run.count;
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

// The sum of N numbers over a stretch of consecutive bonds b, b + 1, ... with the same bond_i,
// added to that quanta's row once, when the stretch ends (it may go on into the part's next run).
// The stretches are the same for any partition, so the sums are too. One per part, on its thread.
template <int N>
struct BondStretch {
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

}  // namespace qbond
