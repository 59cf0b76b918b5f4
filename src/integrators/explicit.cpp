// Explicit integrators: the particle method and its better-behaved relatives.
#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <functional>

#include "integrators/affine_run_terms.hpp"
#include "integrators/bond_forces.hpp"
#include "integrators/integrator_common.hpp"
#include "integrators/penalty_contact.hpp"
#include "integrators/ranks_link.hpp"
#include "core/parallel.hpp"
#include "core/simd.hpp"

namespace qbond {
namespace {

// Velocity Verlet's carry-over (VerletForces) as the passes address it: the rows of the bond
// forces f₁ and of the positions x₁ the step left (the force pass's own rows, written there by the
// stage and the pass), and its v₁. T is double or const double.
template <class T>
struct VerletRows {
  T* f[3];
  T* x[3];
  T* v;
  template <class Forces>
  explicit VerletRows(Forces& c) : v(c.v.data()->data()) {
    for (std::size_t k = 0; k < 3; ++k) {
      f[k] = c.f.data() + k * c.stride();
      x[k] = c.x.data() + k * c.stride();
    }
  }
};

// Three read-only arrays, one per component, passed by value (their pointers then stay in
// registers through a vector loop).
struct Columns {
  const double* c[3];
};

// Verlet's first half for quanta [lo, hi), from the step's first accelerations a = m⁻¹ (f0 + f_ext):
// the free quanta's Δx = h v + h²/2 a into dx unless the step advances in place (kDx false; 0 for
// kinematic ones: the prescribed ones' rows, project_kinematic's, are written after); x₁ = x + Δx,
// as the step will apply it, into the bond pass's rows (the next carry-over's); the velocity the
// forces are taken at, ṽ = v + h a (kinematic: v), into the rows; the force sums zeroed. Returns
// whether x and v equal cx and cv bit for bit.
template <bool kDx, bool kGravity>
QBOND_VECTOR_INLINE bool stage_range(const double* inv_mass, Columns f0, External f_ext, const double* x,
                                     const double* v, Columns cx, const double* cv, double h, double* dx,
                                     ForceRows rows, std::size_t lo, std::size_t hi) {
  const double hh = 0.5 * h * h;
  std::uint64_t differ = 0;
  QBOND_SIMD_OR(differ) for (std::size_t q = lo; q < hi; ++q) {
    QBOND_UNROLL(3) for (std::size_t c = 0; c < 3; ++c) {
      const std::size_t e = 3 * q + c;
      const double xe = x[e], ve = v[e];
      differ |= (std::bit_cast<std::uint64_t>(xe) ^ std::bit_cast<std::uint64_t>(cx.c[c][q])) |
                (std::bit_cast<std::uint64_t>(ve) ^ std::bit_cast<std::uint64_t>(cv[e]));
      const double ae = inv_mass[q] * (f0.c[c][q] + f_ext.at<kGravity>(q, c));
      const double step = h * ve + hh * ae, vt = ve + h * ae;
      const double d = inv_mass[q] != 0 ? step : 0.0;
      if constexpr (kDx) dx[e] = d;
      rows.x[c][q] = xe + d;
      rows.v[c][q] = inv_mass[q] != 0 ? vt : ve;
      rows.f[c][q] = 0;
    }
  }
  return differ == 0;
}

// stage_range, writing dx unless it is null.
QBOND_VECTOR_CLONES bool verlet_stage(const double* inv_mass, Columns f0, External f_ext, const double* x,
                                      const double* v, Columns cx, const double* cv, double h, double* dx,
                                      ForceRows rows, std::size_t lo, std::size_t hi) {
  if (!f_ext.f)
    return dx ? stage_range<true, true>(inv_mass, f0, f_ext, x, v, cx, cv, h, dx, rows, lo, hi)
              : stage_range<false, true>(inv_mass, f0, f_ext, x, v, cx, cv, h, dx, rows, lo, hi);
  return dx ? stage_range<true, false>(inv_mass, f0, f_ext, x, v, cx, cv, h, dx, rows, lo, hi)
            : stage_range<false, false>(inv_mass, f0, f_ext, x, v, cx, cv, h, dx, rows, lo, hi);
}

// Where verlet_finish writes: Δv into dv, or for a step advanced in place (kApplied; dv null) x₁
// (the bond pass's rows' x) and v₁ into the state the step applies, x_to and v_to.
struct FinishOut {
  double* dv;
  double* x_to;
  double* v_to;
};

// Verlet's second half for quanta [lo, hi): with the bond forces at the stage in rows.f (the
// carry-over's f₁), the free quanta's Δv = h/2 (m⁻¹ (f0 + f_ext) + m⁻¹ (f1 + f_ext)) (0 for
// kinematic ones) and v₁ = v + Δv into v1; Δv, or x₁ and v₁, into `out`. Returns, for a step
// advanced in place, whether every quanta keeps the blow-up rule (QuantaCheck); true otherwise.
template <bool kApplied, bool kGravity>
QBOND_VECTOR_INLINE bool finish_range(const double* inv_mass, ForceRows rows, External f_ext, Columns f0,
                                      const double* v, double h, double limit2, double* v1, FinishOut out,
                                      std::size_t lo, std::size_t hi) {
  std::uint64_t bad = 0;
  QBOND_SIMD_OR(bad) for (std::size_t q = lo; q < hi; ++q) {
    QuantaCheck check;
    QBOND_UNROLL(3) for (std::size_t c = 0; c < 3; ++c) {
      const std::size_t e = 3 * q + c;
      const double fe = f_ext.at<kGravity>(q, c);
      const double kick = (0.5 * h) * (inv_mass[q] * (f0.c[c][q] + fe) + inv_mass[q] * (rows.f[c][q] + fe));
      const double d = inv_mass[q] != 0 ? kick : 0.0;
      const double ve = v[e] + d;
      v1[e] = ve;
      if constexpr (kApplied) {
        const double xe = rows.x[c][q];
        out.x_to[e] = xe;
        out.v_to[e] = ve;
        check.add(xe, ve);
      } else {
        out.dv[e] = d;
      }
    }
    if constexpr (kApplied) bad |= check.bad(limit2, inv_mass[q] != 0);
  }
  return bad == 0;
}

// finish_range, into the applied state if out.dv is null.
QBOND_VECTOR_CLONES bool verlet_finish(const double* inv_mass, ForceRows rows, External f_ext, Columns f0,
                                       const double* v, double h, double limit2, double* v1, FinishOut out,
                                       std::size_t lo, std::size_t hi) {
  if (!f_ext.f)
    return out.dv ? finish_range<false, true>(inv_mass, rows, f_ext, f0, v, h, limit2, v1, out, lo, hi)
                  : finish_range<true, true>(inv_mass, rows, f_ext, f0, v, h, limit2, v1, out, lo, hi);
  return out.dv ? finish_range<false, false>(inv_mass, rows, f_ext, f0, v, h, limit2, v1, out, lo, hi)
                : finish_range<true, false>(inv_mass, rows, f_ext, f0, v, h, limit2, v1, out, lo, hi);
}

// Verlet and RK4 evaluate damping halfway through the velocity change on average; both Euler
// variants at the start-of-step velocity.
LedgerHints explicit_hints(IntegratorType type) {
  const bool half = type == IntegratorType::velocity_verlet || type == IntegratorType::rk4;
  return {.damping_theta = half ? 0.5 : 0.0};
}

class ExplicitIntegrator final : public StepIntegrator {
 public:
  explicit ExplicitIntegrator(const IntegratorConfig& c) : StepIntegrator(c, explicit_hints(c.type)) {}

  bool forms_gravity() const override { return config_.type == IntegratorType::velocity_verlet; }

  // Verlet's fused kernel writes the state the step applies in its last pass. With penalty
  // contacts the step is projected and applied, as with the ledger on: the same bits either way.
  void advance(const Model& model, const State& state, const Adjacency& adj, const std::vector<Vec3>& f_ext,
               const StepContext& ctx, Projection& out, Advanced& to) override {
    if (config_.type != IntegratorType::velocity_verlet || PenaltyContact::used(model))
      return StepIntegrator::advance(model, state, adj, f_ext, ctx, out, to);
    part_.update(model, state.bonds, adj, config_.threads);
    verlet(model, state, adj, f_ext, ctx, out, &to);
  }

  void project(const Model& model, const State& state, const Adjacency& adj,
               const std::vector<Vec3>& f_ext, const StepContext& ctx, Projection& out) override {
    const std::size_t n = model.num_quanta();
    const double h = ctx.h;
    part_.update(model, state.bonds, adj, config_.threads);
    const bool verlet_step = config_.type == IntegratorType::velocity_verlet;
    if (verlet_step) return verlet(model, state, adj, f_ext, ctx, out, nullptr);
    // The Euler steps write every row (euler_rows): dx and dv are not zeroed first.
    const bool rk4 = config_.type == IntegratorType::rk4;
    out.resize(n, /*zero=*/rk4);
    if (rk4) project_kinematic(model, state, ctx, out);  // its stages read the kinematic rows
    const bool contact = begin_contact(model);
    // a(x, v), with the penalty contacts' forces taken over the fraction w of the step.
    auto forces_at = [&](const std::vector<Vec3>& x, const std::vector<Vec3>& v, double w, std::vector<Vec3>& a) {
      accelerations(model, state, part_, x, v, f_ext, config_.threads, forces_, a);
      if (!contact) return;
      contact_step(model, adj, h, w, PointsView::of(x.data(), v.data()));
      for (const PenaltyContact::Force& c : contact_.forces()) a[c.i] += model.inv_mass[c.i] * c.f;
    };
    forces_at(state.x, state.v, rk4 ? 1.0 / 6 : 1.0, a1_);
    switch (config_.type) {
      case IntegratorType::explicit_euler:
        euler_rows(model, state, ctx, out, [&](std::size_t i) { set_free(out, i, h * state.v[i], h * a1_[i]); });
        break;
      case IntegratorType::symplectic_euler:
        euler_rows(model, state, ctx, out, [&](std::size_t i) {
          const Vec3 dv = h * a1_[i];
          set_free(out, i, h * (state.v[i] + dv), dv);
        });
        break;
      case IntegratorType::rk4: {
        // Classical RK4 on (x' = v, v' = a(x, v)); kinematic quanta sit on their prescribed
        // path, interpolated linearly over the step. Over ranks a ghost's stage velocity is its
        // owner's (its own acceleration here lacks its bonds off the piece); its stage position
        // follows from the velocities alone.
        stage(model, state, out, 0.5, [&](std::size_t i) {
          return std::pair{Vec3(0.5 * h * state.v[i]), Vec3(0.5 * h * a1_[i])};
        });
        if (ranks_) ranks_->exchange(vs_);
        v2_ = vs_;
        forces_at(xs_, vs_, 1.0 / 3, a2_);
        stage(model, state, out, 0.5, [&](std::size_t i) {
          return std::pair{Vec3(0.5 * h * v2_[i]), Vec3(0.5 * h * a2_[i])};
        });
        if (ranks_) ranks_->exchange(vs_);
        v3_ = vs_;
        forces_at(xs_, vs_, 1.0 / 3, a3_);
        stage(model, state, out, 1.0, [&](std::size_t i) {
          return std::pair{Vec3(h * v3_[i]), Vec3(h * a3_[i])};
        });
        if (ranks_) ranks_->exchange(vs_);
        forces_at(xs_, vs_, 1.0 / 6, a4_);
        for_free(model, [&](std::size_t i) {
          set_free(out, i, (h / 6) * (state.v[i] + 2 * v2_[i] + 2 * v3_[i] + vs_[i]),
                   (h / 6) * (a1_[i] + 2 * a2_[i] + 2 * a3_[i] + a4_[i]));
        });
        break;
      }
      default:
        break;
    }
    if (!contact) return;
    // The springs' energy at the step's end (x₁, v₁ into xs_, vs_).
    stage(model, state, out, 1.0, [&](std::size_t i) { return std::pair{out.dx[i], out.dv[i]}; });
    contact_.evaluate(model, adj, h, PointsView::of(xs_.data(), vs_.data()), counted_);
    finish_contact(model, state.v, vs_.data(), out);
  }

 private:
  // Velocity Verlet in Groot and Warren's form with λ = 1 (J. Chem. Phys. 107, 4423, 1997):
  //   x₁ = x + h v + h²/2 a,   a₁ = a(x₁, ṽ) with ṽ = v + h a,   v₁ = v + h/2 (a + a₁),
  // where a is the last step's a₁ (first same as last: one force pass a step). Undamped, a does
  // not depend on the velocity and this is velocity Verlet itself; with damping, ṽ − v₁ =
  // h/2 (a − a₁) = O(h²) keeps the step second order. The last step's bond forces travel in
  // State::carry with the x₁, v₁ it left (VerletForces); when the state is not exactly that (a
  // heuristic, a contact, a rollback or the user changed it) a = a(x, v) is evaluated afresh.
  // With `to`, the step is advanced in place (advance.hpp): x₁ and v₁ go there, checked.
  void verlet(const Model& model, const State& state, const Adjacency& adj, const std::vector<Vec3>& f_ext,
              const StepContext& ctx, Projection& out, Advanced* to) {
    const std::size_t n = model.num_quanta();
    const double h = ctx.h;
    const int threads = config_.threads;
    out.resize(to ? 0 : n, false);  // every row written; clears the carry-over before keep()
    if (to) {
      to->x.resize(n);
      to->v.resize(n);
    }
    VerletForces& kept = out.keep<VerletForces>();
    kept.resize(n);
    kept.topology_version = state.topology_version();
    const VerletRows<double> next(kept);
    // The bond pass's rows: f₁ and x₁ in the new carry-over, ṽ in forces_.
    ForceRows rows = force_rows(forces_, n);
    for (std::size_t c = 0; c < 3; ++c) {
      rows.f[c] = next.f[c];
      rows.x[c] = next.x[c];
    }
    const double* inv_mass = model.inv_mass.data();
    const double* x = state.x.data()->data();
    const double* v = state.v.data()->data();
    const External fe(model, f_ext);
    double* dx = to ? nullptr : out.dx.data()->data();
    const FinishOut finish_out = to ? FinishOut{nullptr, to->x.data()->data(), to->v.data()->data()}
                                    : FinishOut{out.dv.data()->data(), nullptr, nullptr};
    // With the carried forces, for the topology they were left for, while checking that the state
    // is the one they were left for; if it is not, again with a(x, v) evaluated afresh into
    // forces_'s f and x, which the stage does not write (cx is then x itself).
    Columns f0{}, cx{};
    const double* cv = v;
    auto take = [](Columns& to, const auto& from) {
      for (std::size_t c = 0; c < 3; ++c) to.c[c] = from[c];
    };
    if (const auto* c = std::get_if<VerletForces>(&state.carry); c && c->holds_for(n, state.topology_version())) {
      const VerletRows<const double> last(*c);
      take(f0, last.f);
      take(cx, last.x);
      cv = last.v;
    }
    // The prescribed quanta where the step will place them (place_kinematic), written with their
    // range's (PrescribedAt says why).
    prescribed_.update(model, ctx.t + h);
    auto stage = [&](std::size_t lo, std::size_t hi) {
      const bool same = verlet_stage(inv_mass, f0, fe, x, v, cx, cv, h, dx, rows, lo, hi);
      for (const PrescribedAt::Quanta& p : prescribed_.in(lo, hi))
        for (int c = 0; c < 3; ++c) {
          rows.x[c][p.q] = p.x[c];
          rows.v[c][p.q] = p.v[c];
        }
      return same;
    };
    if (!f0.c[0] || !reduce_chunks(n, threads, true, stage, std::logical_and<>{})) {
      const ForceRows fresh = bond_force_rows(model, state, part_, state.x.data(), state.v.data(), threads, forces_);
      take(f0, fresh.f);
      take(cx, fresh.x);
      cv = v;
      reduce_chunks(n, threads, true, stage, std::logical_and<>{});
    }
    // The penalty contacts at the start (x, v) and at the stage (x₁, ṽ), each for half the step's
    // kick: the start's in x₁ and ṽ before the bond pass reads them. (A step with contacts is
    // projected, never advanced in place: advance().)
    const bool contact = begin_contact(model);
    assert(!contact || !to);
    if (contact) {
      contact_step(model, adj, h, 0.5, PointsView::of(state.x.data(), state.v.data()));
      for (const PenaltyContact::Force& c : contact_.forces())
        for (std::size_t k = 0; k < 3; ++k) {
          const std::size_t e = 3 * static_cast<std::size_t>(c.i) + k;
          const double a = model.inv_mass[c.i] * c.f[k];
          dx[e] += 0.5 * h * h * a;
          rows.x[k][c.i] = x[e] + dx[e];  // as the step applies it
          rows.v[k][c.i] += h * a;
        }
    }
    add_bond_forces(model, state, part_, rows);
    if (contact)
      contact_step(model, adj, h, 0.5, PointsView{{rows.x[0], rows.x[1], rows.x[2]}, {rows.v[0], rows.v[1], rows.v[2]}, 1});
    // The prescribed quanta's v₁ as placed (verlet_finish wrote their v), and their rows of the
    // projection (project_kinematic), or of the applied state (place_kinematic: the stage put
    // their x₁ in the rows).
    const double limit2 = to ? to->max_speed * to->max_speed : HUGE_VAL;
    auto finish = [&](std::size_t lo, std::size_t hi) {
      bool ok = verlet_finish(inv_mass, rows, fe, f0, v, h, limit2, next.v, finish_out, lo, hi);
      for (const PrescribedAt::Quanta& p : prescribed_.in(lo, hi)) {
        for (int c = 0; c < 3; ++c) next.v[3 * p.q + c] = p.v[c];
        if (!to) continue;
        to->v[p.q] = p.v;
        ok = ok && p.x.allFinite() && p.v.allFinite();
      }
      if (!to) prescribed_.project(state, lo, hi, out);
      return ok;
    };
    const bool ok = reduce_chunks(n, threads, true, finish, std::logical_and<>{});
    if (to) to->ok = ok;
    if (!contact) return;
    // The contacts' kick m⁻¹ J, J = h/2 (f₀ + f₁), added to v₁ as the step applies it.
    for (std::size_t q = 0; q < n; ++q) {
      if (impulse_[q] == Vec3::Zero()) continue;
      for (std::size_t k = 0; k < 3; ++k) {
        out.dv[q][k] += model.inv_mass[q] * impulse_[q][k];
        next.v[3 * q + k] = v[3 * q + k] + out.dv[q][k];
      }
    }
    finish_contact(model, state.v, kept.v.data(), out);
  }

  // Starts a step's contact books; whether the model has penalty contacts.
  bool begin_contact(const Model& model) {
    if (!PenaltyContact::used(model)) return false;
    impulse_.assign(model.num_quanta(), Vec3::Zero());
    stored_start_ = NAN;
    return true;
  }

  // Evaluates the contacts at p, for the fraction w of the step the integrator gives their forces:
  // their impulse w h f goes to the step's books. The step's first evaluation is at its start.
  void contact_step(const Model& model, const Adjacency& adj, double h, double w, const PointsView& p) {
    contact_.evaluate(model, adj, h, p, counted_);
    if (std::isnan(stored_start_)) stored_start_ = contact_.stored();
    for (const PenaltyContact::Force& c : contact_.forces()) impulse_[c.i] += (w * h) * c.f;
  }

  // out.contact from the step's books, the last evaluation being at the step's end: the impulses'
  // work W = Σ J·(v + v₁)/2 (exactly the kinetic energy they change) and the springs' energy U;
  // what the contacts took out, −W − ΔU, charged when positive (a negative balance is the
  // integrator's error on the stiff spring, left in `numerical`).
  void finish_contact(const Model& model, const std::vector<Vec3>& v, const Vec3* v1, Projection& out) const {
    double work = 0;
    for (std::size_t q = 0; q < model.num_quanta(); ++q)
      if (impulse_[q] != Vec3::Zero() && (counted_.empty() || counted_[q]))
        work += impulse_[q].dot(0.5 * (v[q] + v1[q]));
    const double stored = contact_.stored();
    out.contact = {.dissipated = std::max(0.0, -work - (stored - stored_start_)),
                   .stored = stored,
                   .stored_start = stored_start_,
                   .work = work,
                   .charged = true};
  }

  static void set_free(Projection& out, std::size_t i, const Vec3& dx, const Vec3& dv) {
    out.dx[i] = dx;
    out.dv[i] = dv;
  }

  // Every row of the projection in one pass: body(i) for each free quanta and zeros for each
  // kinematic one, then the prescribed motion of the kinematic ones (project_kinematic's rows). The
  // same rows as zeroing dx and dv, projecting the kinematic quanta and writing the free ones,
  // without the pass that zeroes (a write of 2 × 24 B per quanta).
  template <class Body>
  void euler_rows(const Model& model, const State& state, const StepContext& ctx, Projection& out,
                  Body&& body) const {
    parallel_for(model.num_quanta(), config_.threads, [&](std::size_t i) {
      if (!model.is_kinematic(static_cast<Index>(i)))
        body(i);
      else
        out.dx[i] = out.dv[i] = Vec3::Zero();
    });
    for (const Motion& m : model.motions)
      for (std::size_t k = 0; k < m.quanta.size(); ++k) {
        const Index i = m.quanta[k];
        if (!model.is_kinematic(i)) continue;  // a free quanta keeps body's row
        Vec3 x1, v1;
        m.at(k, ctx.t + ctx.h, x1, v1);
        out.dx[i] = x1 - state.x[i];
        out.dv[i] = v1 - state.v[i];
      }
  }

  // body(i) for every free quanta, on the integrator's threads.
  template <class Body>
  void for_free(const Model& model, Body&& body) const {
    parallel_for(model.num_quanta(), config_.threads, [&](std::size_t i) {
      if (!model.is_kinematic(static_cast<Index>(i))) body(i);
    });
  }

  // Stage state (xs_, vs_) = (x, v) + offsets(i) for free quanta, and the fraction c of the
  // prescribed motion for kinematic quanta.
  template <class Offsets>
  void stage(const Model& model, const State& state, const Projection& kin, double c,
             Offsets offsets) {
    const std::size_t n = model.num_quanta();
    xs_.resize(n);
    vs_.resize(n);
    parallel_for(n, config_.threads, [&](std::size_t i) {
      if (model.is_kinematic(static_cast<Index>(i))) {
        xs_[i] = state.x[i] + c * kin.dx[i];
        vs_[i] = state.v[i] + c * kin.dv[i];
      } else {
        const auto [dx, dv] = offsets(i);
        xs_[i] = state.x[i] + dx;
        vs_[i] = state.v[i] + dv;
      }
    });
  }

  std::vector<Vec3> a1_, a2_, a3_, a4_, xs_, vs_, v2_, v3_;
  PenaltyContact contact_;
  std::vector<Vec3> impulse_;  // per quanta: the contacts' impulse this step
  double stored_start_ = 0;    // the contact springs' energy at the step's start [J]
  BondPartition part_;
  ForceArrays forces_;
  PrescribedAt prescribed_;  // Verlet's
};

std::unique_ptr<StepIntegrator> make_explicit(const IntegratorConfig& config) {
  return std::make_unique<ExplicitIntegrator>(config);
}

}  // namespace

const IntegratorInfo explicit_euler_integrator = {
    IntegratorType::explicit_euler, "explicit_euler", "the particle method: x += h v, v += h a(x, v)", {}, {},
    make_explicit};
const IntegratorInfo symplectic_euler_integrator = {
    IntegratorType::symplectic_euler, "symplectic_euler", "v += h a(x, v), then x += h v_new", {}, {}, make_explicit};
const IntegratorInfo velocity_verlet_integrator = {IntegratorType::velocity_verlet, "velocity_verlet",
                                                   "second order, symplectic when undamped; one force pass a step",
                                                   {}, {}, make_explicit};
const IntegratorInfo rk4_integrator = {
    IntegratorType::rk4, "rk4", "classical fourth-order Runge-Kutta", {}, {}, make_explicit};

}  // namespace qbond
