#pragma once
// The Newton-solved integrators (energy_momentum, implicit_midpoint, bdf2), not public API.
//
// Unknown: y = Δv of the free quanta (kinematic rows hold their prescribed Δv). Each scheme maps
// y to the step's displacement, Δx_i = a_i + c y_i (kinematic: prescribed), takes the bond forces
// somewhere in the step, and solves
//     R_i(y) = m_i (y_i − e_i) − s h (f_ext,i + Σ_b ±f_b(y)) = 0      (free quanta):
//   energy_momentum:   a = h v, c = h/2, s = 1, e = 0 (x₁ − x = h (v + v₁)/2); f_b the discrete
//                      gradient T̄ d_mid / r̄ (newton.cpp, bond_step) and the damper at the midpoint
//                      velocity v + y/2 along the midpoint bond d_mid = (d + d₁)/2;
//   implicit_midpoint: a = h v, c = h/2, s = 1, e = 0; f_b(x + Δx/2, v + y/2);
//   bdf2:              x₁ = 4/3 x − 1/3 x₋₁ + 2/3 h v₁, v₁ = 4/3 v − 1/3 v₋₁ + 2/3 h a(x₁, v₁),
//                      i.e. a = (x − x₋₁)/3 + 2/3 h v, c = 2h/3, s = 2/3, e = (v − v₋₁)/3;
//                      f_b(x₁, v₁);
//   backward_euler:    bdf2's first step (no history): a = h v, c = h, s = 1, e = 0; f_b(x₁, v₁).
// External forces are constant over the step, so their work is f_ext · Δx exactly.
//
// Newton: (M + Σ_b B_b) δ = −R, y += δ, with B_b = s h (c K̃_b + θ C_b) per bond, K̃_b ≈ ∂f_b/∂Δd
// (Δd = Δx_j − Δx_i) and θ = ∂w/∂y the fraction of Δv at which dampers see the velocity (½
// midpoint, 1 end of step). B_b keeps backward_euler.hpp's form a u uᵀ + b I, clamped positive
// semi-definite as there, so that CG, LDLᵀ, dense elimination and the colour-ordered sweeps all
// solve it. For implicit_midpoint, bdf2 and backward Euler K̃_b is the exact tangent of the law
// and of the axial damper's turning (its symmetric part) unless a clamp bites; for
// energy_momentum it drops the discrete gradient's non-symmetric part φ_r1 d_mid (u₁ − u)ᵀ,
// which vanishes when the bond does not turn over the step — a modified Newton whose residual
// is exact, so the converged step keeps every conservation property.
//
// Exact Newton (any solver, when the modified iteration stalls; newton.cpp): J = M + Σ_b B_b with
// the same pattern and B_b = s h (c K_b + θ C_b), K_b = ∂f_b/∂Δd and C_b = ∂f_b/∂w the full 3×3
// derivatives with every non-symmetric part and no clamp, solved by sparse LU. At steps where bonds turn by radians (four quanta at hω = 100: 80°
// to 180° per step) the modified block misses most of J (‖J − Ã‖/‖J‖ = 0.8) and its direction
// stops decreasing ‖R‖; J's symmetric part is indefinite there (docs/integrators.md).
//
// Substepping (energy_momentum, implicit_midpoint; newton.cpp): a step whose iteration still does
// not converge is split in halves, each solved from the state the one before reached, recursively
// down to h/2^8. A composition of discrete-gradient steps keeps E and both momenta as each step
// does; the projection is the composite one, and the anchors' and dampers' work summed over the
// substeps goes to the ledger (SubstepLedger, advance.hpp). bdf2 is not split (its history is one
// whole step back).
//
// Polishing (IntegratorConfig::newton_polish; energy_momentum, implicit_midpoint; newton.cpp): a
// step that met the tolerance takes exact-Newton corrections until ‖R‖ stops decreasing, so that
// the momenta (Σ R and Σ x_mid × R per step) are kept to round-off rather than to the tolerance.
#include <vector>

#include "integrators/backward_euler.hpp"
#include "qbond/integrators/integrators.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

// Substepping fallback of energy_momentum and implicit_midpoint: a step whose Newton iteration does
// not converge is split in halves, at most this many times (2^kNewtonSplitDepth substeps of
// h / 2^kNewtonSplitDepth), the smallest taken anyway; over MPI ranks as alone (distributed_step.cpp).
inline constexpr int kNewtonSplitDepth = 8;

enum class NewtonScheme : std::uint8_t { energy_momentum, implicit_midpoint, bdf2, backward_euler };

// The map from y to the step (see the header comment).
struct NewtonStep {
  NewtonScheme scheme = NewtonScheme::energy_momentum;
  double h = 0, s = 1, c = 0, theta = 0.5;
  bool clamp = true;    // clamp the blocks positive semi-definite (the iterative solvers need it)
  bool exact = false;   // also fill ImplicitSystem::exact with the full blocks (exact Newton)
  std::vector<Vec3> a;  // free: Δx = a + c y; kinematic: the prescribed Δx (n)
  std::vector<Vec3> e;  // (n)
  Vec3 dx(const Model& m, const std::vector<Vec3>& y, Index i) const {
    return m.is_kinematic(i) ? a[i] : Vec3(a[i] + c * y[i]);
  }
};

// Fills `st` for this step. `kin` holds the prescribed rows (project_kinematic); x_prev, v_prev
// are the state of the step before (bdf2 only; null for the other schemes).
void setup_newton_step(NewtonScheme scheme, const Model& model, const State& state, const Projection& kin, double h,
                       const std::vector<Vec3>* x_prev, const std::vector<Vec3>* v_prev, NewtonStep& st);

// Every bond's step at y: force[b] (0 for broken bonds) and, when `sys`, B_b into sys->bonds
// (and, when st.exact, the full B_b into sys->exact).
void newton_bonds(const Model& model, const State& state, const NewtonStep& st, const std::vector<Vec3>& y,
                  int threads, std::vector<Vec3>& force, ImplicitSystem* sys);

// R(y) for free quanta (kinematic rows 0), gathered in bond order. Returns ‖R‖² and the squared
// scale of its terms, Σ_i (|m_i (y_i − e_i)| + s h (|f_ext,i| + Σ_b |f_b|))², against which the
// tolerance is relative (round-off in R is relative to the largest term, not to R's sum).
struct ResidualNorms {
  double r2 = 0, ref2 = 0;
};
ResidualNorms newton_residual(const Model& model, const Bonds& bonds, const Adjacency& adj,
                              const NewtonStep& st, const std::vector<Vec3>& f_ext, const std::vector<Vec3>& force,
                              const std::vector<Vec3>& y, int threads, std::vector<Vec3>& R,
                              std::vector<double>& scale);

}  // namespace qbond
