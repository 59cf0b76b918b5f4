#include "integrators/advance.hpp"

#include <functional>
#include <sstream>

#include "core/parallel.hpp"

namespace qbond {
namespace {

// xn = x + dx and vn = v + dv for quanta [lo, hi); whether every quanta keeps the blow-up rule.
// Branch-free, so the loop vectorises.
QBOND_VECTOR_CLONES bool add_checked(const double* x, const double* v, const double* dx, const double* dv,
                                     const double* inv_mass, double limit2, double* xn, double* vn,
                                     std::size_t lo, std::size_t hi) {
  std::uint64_t bad = 0;
  QBOND_SIMD_OR(bad) for (std::size_t q = lo; q < hi; ++q) {
    QuantaCheck check;
    QBOND_UNROLL(3) for (std::size_t c = 0; c < 3; ++c) {
      const std::size_t e = 3 * q + c;
      const double x1 = x[e] + dx[e], v1 = v[e] + dv[e];
      xn[e] = x1;
      vn[e] = v1;
      check.add(x1, v1);
    }
    bad |= check.bad(limit2, inv_mass[q] != 0);
  }
  return bad == 0;
}

// xn = x + dx and vn = v + dv for quanta [lo, hi) with a solve's dv = y and dx = h (v + dv)
// (write_free_rows' rows, added as add_checked adds them), formed here instead of read; whether
// every free quanta keeps the blow-up rule. The kinematic quanta's rows are not theirs: the
// caller writes and checks them after.
QBOND_VECTOR_CLONES bool add_solved(const double* x, const double* v, const double* y, const double* inv_mass,
                                    double h, double limit2, double* xn, double* vn, std::size_t lo,
                                    std::size_t hi) {
  std::uint64_t bad = 0;
  QBOND_SIMD_OR(bad) for (std::size_t q = lo; q < hi; ++q) {
    QuantaCheck check;
    QBOND_UNROLL(3) for (std::size_t c = 0; c < 3; ++c) {
      const std::size_t e = 3 * q + c;
      const double dv = y[e], dx = h * (v[e] + dv);
      const double x1 = x[e] + dx, v1 = v[e] + dv;
      xn[e] = x1;
      vn[e] = v1;
      check.add(x1, v1);
    }
    bad |= check.bad(limit2, true) & static_cast<std::uint64_t>(inv_mass[q] != 0);
  }
  return bad == 0;
}

}  // namespace

void apply_solved(const Model& model, const State& state, const Projection& kin, const std::vector<Vec3>& y,
                  double h, double t1, int threads, PrescribedAt& prescribed, Advanced& to) {
  const std::size_t n = model.num_quanta();
  to.x.resize(n);
  to.v.resize(n);
  const double* inv_mass = model.inv_mass.data();
  const double limit2 = to.max_speed * to.max_speed;
  prescribed.update(model, t1);
  auto range = [&](std::size_t lo, std::size_t hi) {
    bool ok = add_solved(state.x.data()->data(), state.v.data()->data(), y.data()->data(), inv_mass, h, limit2,
                         to.x.data()->data(), to.v.data()->data(), lo, hi);
    // The kinematic rows after the vector loop, not a select in it (which would stream kin's
    // rows of every quanta).
    for (std::size_t q = lo; q < hi; ++q) {
      if (inv_mass[q] != 0) continue;
      QuantaCheck check;
      for (int c = 0; c < 3; ++c) {
        const double x1 = state.x[q][c] + kin.dx[q][c], v1 = state.v[q][c] + kin.dv[q][c];
        to.x[q][c] = x1;
        to.v[q][c] = v1;
        check.add(x1, v1);
      }
      ok = ok && check.bad(limit2, false) == 0;
    }
    prescribed.place(lo, hi, to.x.data(), to.v.data());
    return ok;
  };
  to.ok = reduce_chunks(n, threads, true, range, std::logical_and<>{});
}

void apply_checked(const Model& model, const State& state, const Projection& p, double t1, int threads,
                   PrescribedAt& prescribed, Advanced& to) {
  const std::size_t n = model.num_quanta();
  to.x.resize(n);
  to.v.resize(n);
  const double* x = state.x.data()->data();
  const double* v = state.v.data()->data();
  const double* dx = p.dx.data()->data();
  const double* dv = p.dv.data()->data();
  double* xn = to.x.data()->data();
  double* vn = to.v.data()->data();
  const double limit2 = to.max_speed * to.max_speed;
  // The prescribed quanta exactly on their path (place_kinematic), so that they do not drift by
  // round-off, placed with their range (PrescribedAt says why).
  prescribed.update(model, t1);
  auto range = [&](std::size_t lo, std::size_t hi) {
    const bool ok = add_checked(x, v, dx, dv, model.inv_mass.data(), limit2, xn, vn, lo, hi);
    prescribed.place(lo, hi, to.x.data(), to.v.data());
    return ok;
  };
  to.ok = reduce_chunks(n, threads, true, range, std::logical_and<>{});
}

void StepIntegrator::advance(const Model& model, const State& state, const Adjacency& adj,
                             const std::vector<Vec3>& f_ext, const StepContext& ctx, Projection& out,
                             Advanced& to) {
  project(model, state, adj, f_ext, ctx, out);
  apply_checked(model, state, out, ctx.t + ctx.h, config_.threads, placed_, to);
}

Blowup find_blowup(const Model& model, std::span<const Vec3> x, std::span<const Vec3> v, double max_speed,
                   const StepContext& ctx, int threads) {
  struct Worst {
    double speed2 = -1;  // squared: a square root only for the message
    Index who = 0;
    bool finite = true;
  };
  auto fold = [&](Worst w, std::size_t i) {
    if (!w.finite) return w;
    if (!v[i].allFinite() || !x[i].allFinite()) return Worst{w.speed2, static_cast<Index>(i), false};
    const double speed2 = v[i].squaredNorm();
    if (!model.is_kinematic(static_cast<Index>(i)) && speed2 > w.speed2)
      return Worst{speed2, static_cast<Index>(i), true};
    return w;
  };
  auto combine = [](const Worst& a, const Worst& b) {
    return !a.finite || (b.finite && b.speed2 <= a.speed2) ? a : b;
  };
  const auto [worst2, who, finite] = deterministic_reduce(model.num_quanta(), threads, Worst{}, fold, combine);
  if (finite && worst2 <= max_speed * max_speed) return {};
  std::ostringstream msg;
  msg.precision(6);
  msg << "blow-up at step " << ctx.step << " (t = " << ctx.t << " s): ";
  if (!finite)
    msg << "quanta " << model.quanta_id[who] << " would get a non-finite position or velocity";
  else
    msg << "quanta " << model.quanta_id[who] << " would reach speed " << std::sqrt(worst2) << " m/s (limit "
        << max_speed << " m/s)";
  return {true, who, msg.str()};
}

void StepIntegrator::apply_substep(const Model& model, const Adjacency& adj, const std::vector<Vec3>& f_ext, double H,
                                   double t1, const Projection& p, State& sub, std::vector<Vec3>& x1,
                                   std::vector<Vec3>& v1) {
  const std::size_t n = model.num_quanta();
  x1.resize(n);
  v1.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    x1[i] = sub.x[i] + p.dx[i];
    v1[i] = sub.v[i] + p.dv[i];
  }
  if (substeps_) substeps_->charge(model, sub, adj, p, x1, v1, f_ext, H);
  sub.x.swap(x1);
  sub.v.swap(v1);
  for (const Motion& motion : model.motions)
    for (std::size_t k = 0; k < motion.quanta.size(); ++k)
      motion.at(k, t1, sub.x[motion.quanta[k]], sub.v[motion.quanta[k]]);
}

}  // namespace qbond
