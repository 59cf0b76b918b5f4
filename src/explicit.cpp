// Explicit integrators: the particle method and its better-behaved relatives.
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
      case IntegratorType::velocity_verlet: {
        // x₁ = x + h v + h²/2 a(x, v); a₁ at x₁ with the velocity v + h a (exact when undamped);
        // v₁ = v + h/2 (a + a₁).
        stage(model, state, out, 1.0, [&](std::size_t i) {
          return std::pair{Vec3(h * state.v[i] + 0.5 * h * h * a1_[i]), Vec3(h * a1_[i])};
        });
        accelerations(model, state, part_, xs_, vs_, f_ext, config_.threads, forces_, a2_);
        for_free(model, [&](std::size_t i) { set_free(out, i, xs_[i] - state.x[i], 0.5 * h * (a1_[i] + a2_[i])); });
        break;
      }
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
