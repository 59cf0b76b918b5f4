#pragma once
// The sums over every alive bond that the energy ledger takes each step (the ledger stage and
// Simulation's check_energy): the dampers' work and the bonds' potential energy. Most of a
// lattice's bonds in locality order come in stretches with affine ends (bond b + k joins i + k and
// j + k, ordering.hpp); eight such bonds at a time are summed by one vector loop over contiguous
// data, the others bond by bond. Summed in chunks fixed by the bond count (parallel.hpp): the same
// bits for any thread count.
#include <span>

#include "qbond/integrators/integrators.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

/// Σ U_b(r_b) over the alive bonds, r_b their lengths at the state's positions (Eqs. 2–3) [J].
double bond_energy_sum(const Model& m, const State& s, int threads);

/// How the bonds' energy changes when the quanta move by dx from the state's positions:
/// Σ U_b(|d₁|) − U_b(|d₀|), d₁ = d₀ + Δx_j − Δx_i, over the alive bonds, each bond's difference formed directly (for the
/// linear law ½ k (r₁ − r₀)(r₁ + r₀ − 2L), exact where the bond barely moves), and the scale of
/// its round-off, Σ |U_b(|d₀|)| + |U_b(|d₁|)| [J]. One pass over the bonds.
struct BondEnergyChange {
  double change = 0;
  double scale = 0;
};
BondEnergyChange bond_energy_change(const Model& m, const State& s, std::span<const Vec3> dx, int threads);

/// The positions and velocities a step applies, x + Δx and v + Δv of every quanta (prescribed
/// ones before they are put on their paths), formed once a step (Simulation's check stage).
struct AppliedState {
  std::span<const Vec3> x, v;
};

/// What a step does to the bonds' side of the ledger, from its start state s and the state a it
/// applies (x₁ = a.x, v₁ = a.v).
struct BondStepSums {
  /// Energy the dampers take out over the step of length h [J]: Σ h D_b (w·d)² / (d·d) for axial
  /// dampers, Σ h D_b |w|² for isotropic ones, with w = w₀ + θ (w₁ − w₀) the relative velocity
  /// (w₀ = v_j − v_i, w₁ = v₁_j − v₁_i) and d = d₀ + φ (d₁ − d₀) the bond (d₀ = x_j − x_i,
  /// d₁ = x₁_j − x₁_i) where the integrator evaluated them. Bonds of zero length along d are
  /// charged nothing.
  double damping = 0;
  /// Σ U_b(|d₁|) (Eqs. 2–3) [J]: the bonds' energy after the step but for round-off where a
  /// prescribed quanta lands on its path instead.
  double energy_after = 0;
  /// With `backward_euler` (θ = 1, φ = 0): Σ Δdᵀ K_c Δd + T₀ u₀·Δd − (U_b(|d₁|) − U_b(|d₀|)),
  /// Δd = d₁ − d₀, T₀ and u₀ the bond's tension and direction at d₀ and K_c the step's stiffness
  /// block there, clamped (laws.hpp): what the solve's linear forces f₀ − K_c Δd leave out of the
  /// bonds' energy change, the bonds' share of backward Euler's numerical damping (step_work.hpp);
  /// ½ Δdᵀ K Δd for quadratic energies with nothing clamped [J]; else 0.
  double step_loss = 0;
};

/// The sums of BondStepSums in one pass over the bonds. The dampers evaluated at the start's
/// bond (φ = 0) and at the start's or end's velocities (θ = 0 or 1), as most integrators take
/// them, read three of the four arrays.
BondStepSums bond_step_sums(const Model& m, const State& s, const AppliedState& a, double h, double theta,
                            double phi, bool backward_euler, int threads);

}  // namespace qbond
