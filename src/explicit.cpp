// Explicit integrators: the particle method and its better-behaved relatives.
#include <cstring>

#include "forces.hpp"
#include "integrator_common.hpp"
#include "parallel.hpp"

namespace qbond {
namespace {

class ExplicitIntegrator final : public Integrator {
 public:
  explicit ExplicitIntegrator(const IntegratorConfig& c) : Integrator(c) {}

  double damping_theta() const override {
    switch (config_.type) {
      case IntegratorType::velocity_verlet:
      case IntegratorType::rk4: return 0.5;
      default: return 0.0;  // both Euler variants evaluate damping at the start-of-step velocity
    }
  }

  void project(const Model& model, const State& state, const Adjacency& adj,
               const std::vector<Vec3>& f_ext, const StepContext& ctx, Projection& out) override {
    const std::size_t n = model.num_quanta();
    const double h = ctx.h;
    out.resize(n);
    project_kinematic(model, state, ctx, out);
    part_.update(model, adj, config_.threads);
    if (config_.type == IntegratorType::velocity_verlet) return verlet(model, state, f_ext, ctx, out);
    accelerations(model, state, part_, state.x, state.v, f_ext, config_.threads, forces_, a1_);
    switch (config_.type) {
      case IntegratorType::explicit_euler:
        for_free(model, [&](std::size_t i) { set_free(out, i, h * state.v[i], h * a1_[i]); });
        break;
      case IntegratorType::symplectic_euler:
        for_free(model, [&](std::size_t i) {
          const Vec3 dv = h * a1_[i];
          set_free(out, i, h * (state.v[i] + dv), dv);
        });
        break;
      case IntegratorType::rk4: {
        // Classical RK4 on (x' = v, v' = a(x, v)); kinematic quanta sit on their prescribed
        // path, interpolated linearly over the step.
        stage(model, state, out, 0.5, [&](std::size_t i) {
          return std::pair{Vec3(0.5 * h * state.v[i]), Vec3(0.5 * h * a1_[i])};
        });
        v2_ = vs_;
        accelerations(model, state, part_, xs_, vs_, f_ext, config_.threads, forces_, a2_);
        stage(model, state, out, 0.5, [&](std::size_t i) {
          return std::pair{Vec3(0.5 * h * v2_[i]), Vec3(0.5 * h * a2_[i])};
        });
        v3_ = vs_;
        accelerations(model, state, part_, xs_, vs_, f_ext, config_.threads, forces_, a3_);
        stage(model, state, out, 1.0, [&](std::size_t i) {
          return std::pair{Vec3(h * v3_[i]), Vec3(h * a3_[i])};
        });
        accelerations(model, state, part_, xs_, vs_, f_ext, config_.threads, forces_, a4_);
        for_free(model, [&](std::size_t i) {
          set_free(out, i, (h / 6) * (state.v[i] + 2 * v2_[i] + 2 * v3_[i] + vs_[i]),
                   (h / 6) * (a1_[i] + 2 * a2_[i] + 2 * a3_[i] + a4_[i]));
        });
        break;
      }
      default:
        break;
    }
  }

 private:
  // Velocity Verlet in Groot and Warren's form with λ = 1 (J. Chem. Phys. 107, 4423, 1997):
  //   x₁ = x + h v + h²/2 a,   a₁ = a(x₁, ṽ) with ṽ = v + h a,   v₁ = v + h/2 (a + a₁),
  // where a is the last step's a₁ (first same as last: one force pass a step). Undamped, a does
  // not depend on the velocity and this is velocity Verlet itself; with damping, ṽ − v₁ =
  // h/2 (a − a₁) = O(h²) keeps the step second order. The last step's bond forces travel in
  // State::warm with the x₁, v₁ it left (carried_forces); when the state is not exactly that
  // (a heuristic, a contact, a rollback or the user changed it) a = a(x, v) is evaluated afresh.
  void verlet(const Model& model, const State& state, const std::vector<Vec3>& f_ext, const StepContext& ctx,
              Projection& out) {
    const std::size_t n = model.num_quanta();
    const double h = ctx.h;
    const Vec3* f0 = state.warm.data();
    if (!carried_forces(state, n)) {
      a2_.resize(n);
      bond_force_sums(model, state, part_, state.x.data(), state.v.data(), config_.threads, forces_, a2_.data());
      f0 = a2_.data();
    }
    // The new carry-over: [bond forces at (x₁, ṽ) | x₁ | v₁ | (topology version, 0, 0)].
    out.warm.resize(3 * n + 1);
    out.warm_needs_bonds = true;
    Vec3* f1 = out.warm.data();
    Vec3* x1 = f1 + n;
    Vec3* v1 = x1 + n;
    a1_.resize(n);
    vs_.resize(n);
    // x₁ = x + Δx as the step will apply it, bit for bit (the kinematic quanta's Δx comes from
    // project_kinematic, and place_kinematic puts them where the step will).
    for_all(model, [&](std::size_t i) {
      const Vec3 a = model.inv_mass[i] * (f0[i] + f_ext[i]);
      a1_[i] = a;
      if (!model.is_kinematic(static_cast<Index>(i))) {
        out.dx[i] = h * state.v[i] + (0.5 * h * h) * a;
        vs_[i] = state.v[i] + h * a;
      } else {
        vs_[i] = state.v[i] + out.dv[i];
      }
      x1[i] = state.x[i] + out.dx[i];
    });
    place_kinematic(model, ctx.t + h, x1, vs_.data());
    bond_force_sums(model, state, part_, x1, vs_.data(), config_.threads, forces_, f1);
    for_all(model, [&](std::size_t i) {
      if (!model.is_kinematic(static_cast<Index>(i)))
        out.dv[i] = (0.5 * h) * (a1_[i] + model.inv_mass[i] * (f1[i] + f_ext[i]));
      v1[i] = state.v[i] + out.dv[i];
    });
    place_kinematic(model, ctx.t + h, x1, v1);
    out.warm[3 * n] = Vec3(static_cast<double>(state.topology_version), 0, 0);
  }

  // Whether State::warm holds the bond forces a Verlet step left for the state it left, and the
  // state is still exactly that one: same topology, positions and velocities bit for bit. (Edits
  // of bond parameters that keep the topology drop the carry-over: Projection::bonds_edited.)
  static bool carried_forces(const State& state, std::size_t n) {
    if (state.warm.size() != 3 * n + 1 || state.warm[3 * n][0] != static_cast<double>(state.topology_version))
      return false;
    const std::size_t bytes = n * sizeof(Vec3);
    return std::memcmp(state.warm.data() + n, state.x.data(), bytes) == 0 &&
           std::memcmp(state.warm.data() + 2 * n, state.v.data(), bytes) == 0;
  }

  // body(i) for every quanta, on the integrator's threads.
  template <class Body>
  void for_all(const Model& model, Body&& body) const {
    parallel_for(model.num_quanta(), config_.threads, body);
  }

  static void set_free(Projection& out, std::size_t i, const Vec3& dx, const Vec3& dv) {
    out.dx[i] = dx;
    out.dv[i] = dv;
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
  BondPartition part_;
  ForceArrays forces_;
};

}  // namespace

std::unique_ptr<Integrator> make_explicit_integrator(const IntegratorConfig& config) {
  return std::make_unique<ExplicitIntegrator>(config);
}

}  // namespace qbond
