#include "integrators/bond_forces.hpp"

#include <algorithm>
#include <cmath>

#include "integrators/affine_run_terms.hpp"
#include "core/parallel.hpp"
#include "core/simd.hpp"

namespace qbond {

void bond_forces(const Model& model, const State& state, const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                 int threads, std::vector<Vec3>& force) {
  force.resize(state.bonds.size());
  parallel_for(state.bonds.size(), bond_pass_threads(model.num_quanta(), threads), [&](std::size_t b) {
    if (!state.bonds.alive[b]) {
      force[b].setZero();
      return;
    }
    const Index i = state.bonds.i[b], j = state.bonds.j[b];
    force[b] = state.bonds.force_on_i(model.shapes, b, x[j] - x[i], v[j] - v[i], state.bonds.rest[b]);
  });
}

namespace {

// A run's bond forces, by bond k of the run: on bond_i and on bond_j (its negative); −0.0 in the
// lanes past an affine run.
struct ForceTerms {
  alignas(64) double fi[3][kBondRun], fj[3][kBondRun];
};

// f = f_ext (0 when f_ext is null) and the copies of x and v, for quanta [lo, hi).
QBOND_VECTOR_CLONES void start_forces(const Vec3* x, const Vec3* v, const Vec3* f_ext, const ForceRows& rows,
                                      std::size_t lo, std::size_t hi) {
  const double* xp = x->data();
  const double* vp = v->data();
  QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
    QBOND_UNROLL(3) for (std::size_t c = 0; c < 3; ++c) {
      rows.x[c][q] = xp[3 * q + c];
      rows.v[c][q] = vp[3 * q + c];
    }
  }
  if (f_ext) {
    const double* fp = f_ext->data();
    QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
      QBOND_UNROLL(3) for (std::size_t c = 0; c < 3; ++c) rows.f[c][q] = fp[3 * q + c];
    }
  } else {
    for (std::size_t c = 0; c < 3; ++c) std::fill(rows.f[c] + lo, rows.f[c] + hi, 0.0);
  }
}

// An affine run of linear bonds with one damping model (kAxial: axial), bond_force_on_i's
// arithmetic in one vector loop over the run's whole vectors, both ends' sums updated in bond order
// (affine_run_terms.hpp): from that loop when the run is fusable, else from the run's term arrays.
template <bool kAxial>
QBOND_VECTOR_INLINE void linear_affine_forces(const State& state, const ForceRows& rows, const BondRun& run,
                                              ForceTerms& t) {
  const RunParameters p(state, run);
  const double *k = p.k, *L = p.L, *D = p.D;  // named, not bound: lambdas capture them (clang 14)
  const std::size_t i0 = run.i0, j0 = run.j0;
  const Local<3> x(rows.x), v(rows.v);
  auto forces = [=](std::size_t q, double(&fi)[3], double(&fj)[3]) QBOND_LAMBDA_INLINE {
    const std::size_t i = i0 + q, j = j0 + q;
    double d[3], w[3];
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) {
      d[c] = x[c][j] - x[c][i];
      w[c] = v[c][j] - v[c][i];
    }
    const double r = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    const bool ok = r > 0;
    const double inv_r = 1.0 / (ok ? r : 1.0);
    const double T = k[q] * (r - L[q]);
    const double wd = w[0] * d[0] + w[1] * d[1] + w[2] * d[2];
    const double s = kAxial ? (T + D[q] * wd * inv_r) * inv_r : T * inv_r;
    QBOND_UNROLL(3) for (int c = 0; c < 3; ++c) {
      fi[c] = ok ? (kAxial ? s * d[c] : s * d[c] + D[q] * w[c]) : 0.0;
      fj[c] = -fi[c];
    }
  };
  add_affine_terms(run, rows.f, forces, {t.fi[0], t.fi[1], t.fi[2]}, {t.fj[0], t.fj[1], t.fj[2]});
}

QBOND_VECTOR_INLINE void affine_forces(const State& state, const ForceRows& rows,
                                       const BondRun& run, bool axial, ForceTerms& t) {
  prefetch_parameters(state, run);
  if (axial)
    linear_affine_forces<true>(state, rows, run, t);
  else
    linear_affine_forces<false>(state, rows, run, t);
}

// Any other run, bond by bond: each bond's force added to the ends the part owns.
void run_forces(const Model& model, const State& state, const BondRun& run, const ForceRows& rows) {
  auto at = [](double* const (&a)[3], Index q) { return Vec3(a[0][q], a[1][q], a[2][q]); };
  for (Index k = 0; k < run.count; ++k) {
    const Index b = run.bond(k), i = state.bonds.i[b], j = state.bonds.j[b];
    const Vec3 fb = state.bonds.force_on_i(model.shapes, b, at(rows.x, j) - at(rows.x, i),
                                           at(rows.v, j) - at(rows.v, i), state.bonds.rest[b]);
    for (int c = 0; c < 3; ++c) {
      if (run.owns(i)) rows.f[c][i] += fb[c];
      if (run.owns(j)) rows.f[c][j] -= fb[c];
    }
  }
}

// A part's runs' forces (for_each_part_runs). The same runs for every partition
// (bond_partition.hpp), so the same path for each bond.
QBOND_VECTOR_CLONES void part_forces(const Model& model, const State& state, std::span<const BondRun> runs,
                                     const ForceRows& rows, ForceTerms& t) {
  for (const BondRun& run : runs) {
    if (run.kind >= 0)
      affine_forces(state, rows, run, run.kind == 0, t);
    else
      run_forces(model, state, run, rows);
  }
}

// out = f / m (per_mass: inv_mass 0, kinematic, gives 0) or f, for quanta [lo, hi).
QBOND_VECTOR_CLONES void write_out(const Model& model, const ForceRows& rows, bool per_mass, std::size_t lo,
                                   std::size_t hi, Vec3* out) {
  const double* inv_mass = model.inv_mass.data();
  double* o = out->data();
  if (per_mass) {
    QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
      QBOND_UNROLL(3) for (std::size_t c = 0; c < 3; ++c) o[3 * q + c] = rows.f[c][q] * inv_mass[q];
    }
  } else {
    QBOND_SIMD for (std::size_t q = lo; q < hi; ++q) {
      QBOND_UNROLL(3) for (std::size_t c = 0; c < 3; ++c) o[3 * q + c] = rows.f[c][q];
    }
  }
}

// work's rows with x, v and f_ext (0 when null) + the bond forces at them.
ForceRows force_sums(const Model& model, const State& state, const BondPartition& part, const Vec3* x, const Vec3* v,
                     const Vec3* f_ext, int threads, ForceArrays& work) {
  const std::size_t n = model.num_quanta();
  const ForceRows rows = force_rows(work, n);
  parallel_ranges(n, threads, [&](std::size_t lo, std::size_t hi) { start_forces(x, v, f_ext, rows, lo, hi); });
  add_bond_forces(model, state, part, rows);
  return rows;
}

// f_ext + the bond forces at x and v, divided by the masses if per_mass, into out.
void force_pass(const Model& model, const State& state, const BondPartition& part, const Vec3* x, const Vec3* v,
                const Vec3* f_ext, int threads, bool per_mass, ForceArrays& work, Vec3* out) {
  const ForceRows rows = force_sums(model, state, part, x, v, f_ext, threads, work);
  parallel_ranges(model.num_quanta(), threads,
                  [&](std::size_t lo, std::size_t hi) { write_out(model, rows, per_mass, lo, hi, out); });
}

const Vec3* external(const std::vector<Vec3>& f_ext) { return f_ext.empty() ? nullptr : f_ext.data(); }

}  // namespace

ForceRows force_rows(ForceArrays& work, std::size_t n) {
  ForceRows rows;
  SoaArrays soa(work.data, n, 9);
  soa.take(rows.f);
  soa.take(rows.x);
  soa.take(rows.v);
  return rows;
}

void add_bond_forces(const Model& model, const State& state, const BondPartition& part, const ForceRows& rows) {
  for_each_part_runs<ForceTerms>(part, [&](std::span<const BondRun> runs, ForceTerms& t) {
    part_forces(model, state, runs, rows, t);
  });
}

void bond_force_sums(const Model& model, const State& state, const BondPartition& part, const std::vector<Vec3>& x,
                     const std::vector<Vec3>& v, const std::vector<Vec3>& f_ext, int threads, ForceArrays& work,
                     std::vector<Vec3>& f) {
  f.resize(model.num_quanta());
  force_pass(model, state, part, x.data(), v.data(), external(f_ext), threads, false, work, f.data());
}

ForceRows bond_force_rows(const Model& model, const State& state, const BondPartition& part, const Vec3* x,
                          const Vec3* v, int threads, ForceArrays& work) {
  return force_sums(model, state, part, x, v, nullptr, threads, work);
}

void accelerations(const Model& model, const State& state, const BondPartition& part, const std::vector<Vec3>& x,
                   const std::vector<Vec3>& v, const std::vector<Vec3>& f_ext, int threads, ForceArrays& work,
                   std::vector<Vec3>& a) {
  a.resize(model.num_quanta());
  force_pass(model, state, part, x.data(), v.data(), external(f_ext), threads, true, work, a.data());
}

}  // namespace qbond
