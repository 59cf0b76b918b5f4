#pragma once
// Pieces shared by the integrator implementations (not public API).
#include <memory>
#include <span>
#include <vector>

#include "solvers/coloring.hpp"
#include "integrators/advance.hpp"
#include "qbond/integrators/integrators.hpp"
#include "core/simd.hpp"

namespace qbond {

// Each integrator's row, defined in its own file (QBOND_INTEGRATORS lists them).
#define QBOND_INTEGRATOR_ROW(name) extern const IntegratorInfo name##_integrator;
QBOND_INTEGRATORS(QBOND_INTEGRATOR_ROW)
#undef QBOND_INTEGRATOR_ROW

// Every warm start: what hybrid_implicit and coupled_implicit take.
inline constexpr WarmStart kEveryWarmStart[] = {WarmStart::zero, WarmStart::external, WarmStart::previous,
                                                WarmStart::automatic, WarmStart::extrapolated};

// The external force on quanta i: f_ext's, or m_i g for gravity alone (an empty f_ext:
// StepIntegrator::forms_gravity), with the bits of Simulation's.
inline Vec3 external_force(const Model& model, const std::vector<Vec3>& f_ext, Index i) {
  return f_ext.empty() ? Vec3(model.mass[i] * model.gravity) : f_ext[i];
}

// The same for the vector kernels, by component: f_ext as doubles, or m_q g where f is null
// (kGravity; passed by value, its pointers stay in registers through a loop).
struct External {
  const double* f;
  const double* mass;
  double g[3];
  External(const Model& model, const std::vector<Vec3>& f_ext)
      : f(f_ext.empty() ? nullptr : f_ext.data()->data()),
        mass(model.mass.data()),
        g{model.gravity.x(), model.gravity.y(), model.gravity.z()} {}
  template <bool kGravity>
  QBOND_VECTOR_INLINE double at(std::size_t q, std::size_t c) const {
    return kGravity ? mass[q] * g[c] : f[3 * q + c];
  }
};

// The warm start `config` asks for, `automatic` resolved: extrapolated for coupled_implicit with
// the cg solver, zero otherwise. Every maker of an integrator resolves it so (initial_guess
// takes no `automatic`).
WarmStart resolved_warm_start(const IntegratorConfig& config);

// Initial guess of an iterative solve for the free quanta's Δv (kinematic rows 0) from
// State::carry as keep_guess left it; false when it is zero (WarmStart::zero, or no previous step), which
// spares CG its first product. On `threads` (parallel.hpp), as keep_guess and write_free_rows:
// per-quanta loops left on one thread are what keeps a second from speeding up a step.
bool initial_guess(WarmStart mode, const Model& model, const std::vector<Vec3>& f_ext, double h,
                   const Carry& carry, int threads, std::vector<Vec3>& y);

// The carry-over a step of length h whose solve found y leaves in out.carry for the next one's
// initial_guess (`carry` as the step found it): SolverGuess y for WarmStart::previous; for
// extrapolated, SolverGuessPair of y, the Δv before it (zeros if none) and their lengths (the
// one before 0 if unknown); nothing otherwise.
void keep_guess(WarmStart mode, const std::vector<Vec3>& y, double h, const Carry& carry, int threads,
                Projection& out);

// Caches what depends only on the topology and the free quanta (colours, free components), rebuilt
// when either changes.
struct TopologyCache {
  std::uint64_t version = ~0ull;
  std::size_t num_quanta = 0;
  std::size_t motions = 0;  // World::prescribe during a run adds one: the free quanta changed
  Coloring coloring;
  FreeComponents components;
  void update(const Model& model, const Adjacency& adj);
};

// CG's iteration cap: max_iterations, or three times the free unknowns' count when 0.
inline int cg_cap(const IntegratorConfig& c, const TopologyCache& topo) {
  return c.max_iterations > 0 ? c.max_iterations : static_cast<int>(3 * topo.coloring.quanta.size());
}

// Moves every lone quanta (no bonds) in free fall by −½ h² g: backward Euler's x + h v₁ puts it
// ½ h² g ahead of the exact x + h v + ½ h² g each step (it loses ½ m g² h² of energy). In free
// fall: its external force is m g and it is not `touching` a contact (one flag per quanta, or
// empty: none); its impact steps are followed exactly by the contacts (contact_solve.hpp). Bodies
// keep backward Euler's step, whose damping their contacts' active sets rely on.
void fall_freely(const Model& model, const FreeComponents& comps, const std::vector<Vec3>& f_ext, double h,
                 const std::vector<std::uint8_t>& touching, Projection& out);
/// fall_freely's move of one lone quanta i, when in free fall.
void fall_freely(const Model& model, Index i, const std::vector<Vec3>& f_ext, double h,
                 const std::vector<std::uint8_t>& touching, Projection& out);

// Gives every free component (no bond to a kinematic quanta) its exact momentum change over the
// step, h Σ f_ext, by a uniform velocity shift: an iterative solve stopped early leaves a small
// momentum error that would otherwise accumulate (a free body creeping or falling too slowly).
// Components with a quanta marked in `skip` (not empty: one flag per quanta) are left alone: an
// obstacle's impulse is part of their momentum change.
void restore_component_momentum(const Model& model, const FreeComponents& comps,
                                const std::vector<Vec3>& f_ext, double h, std::vector<Vec3>& dv,
                                const std::vector<std::uint8_t>& skip = {});

// Backward Euler's kinetic share of its numerical damping (Projection::kinetic_loss):
// ½ Σ m |Δv|² over the quanta that are free and have bonds in `adj`, less their contacts'
// ½ Σ J·Δv (out.contact.impulse_dv, when charged). A quanta without bonds moves along its exact
// flight and bounce, and loses nothing. Over every quanta, or over `quanta` (a rank's own).
double kinetic_loss(const Model& model, const Adjacency& adj, const Projection& out, int threads);
double kinetic_loss(const Model& model, const Adjacency& adj, const Projection& out, std::span<const Index> quanta);

// Writes the free quanta's rows of a projection from Δv: dx = h (v + Δv) (Eq. 10).
void write_free_rows(const Model& model, const State& state, double h, const std::vector<Vec3>& dv,
                     int threads, Projection& out);

}  // namespace qbond
