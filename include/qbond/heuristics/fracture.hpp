#pragma once
/// Fracture and plasticity (docs/heuristics.md): heuristics that edit bonds from their projected
/// end-of-step length, so that a step never applies a state a rule forbids.
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "qbond/heuristics/heuristics.hpp"

namespace qbond {

/// Bond breaking: a bond whose strain (r - L)/L, compression (L - r)/L or tension at the
/// projected positions passes its threshold breaks, or one whose ends are over-stressed (virial
/// stress of stress.hpp at the projected state, mean of the two ends: its normal stress along
/// the bond n·σ·n, a Rankine criterion that opens cracks across the largest principal stress, or
/// its von Mises stress), with `probability` per step (the paper's
/// random breaking under extreme stress; drawn from State::rng in bond order, so the cracks
/// depend on the seed only). The bond's stored energy at that length is charged as dissipated.
/// A bond whose law declares a failure stretch (the cohesive law's s_f) and has reached it is left
/// to the step, which breaks it after the heuristics whether a break rule is on or not (reason
/// `failure`, no draw).
struct BreakRule {
  double max_strain = std::numeric_limits<double>::infinity();
  double max_compression = std::numeric_limits<double>::infinity();
  double max_tension = std::numeric_limits<double>::infinity();  ///< [N]
  double max_stress = std::numeric_limits<double>::infinity();     ///< n·σ·n [Pa]
  double max_von_mises = std::numeric_limits<double>::infinity();  ///< [Pa]
  double probability = 1;  ///< chance per step that an over-threshold bond breaks, in (0, 1]
  /// Per quanta: 1 when selected; the rule applies to bonds with both ends selected (empty: all).
  std::vector<std::uint8_t> quanta{};
  /// Whether a stress limit is set: the rule then reads the quanta's virial stress.
  bool reads_stress() const { return std::isfinite(max_stress) || std::isfinite(max_von_mises); }
};

/// Bilinear elastoplastic bonds with linear kinematic hardening. In strain units from the
/// original rest length L₀ (Bonds::rest0): elastic strain e = (r - L)/L₀, plastic strain
/// p = (L - L₀)/L₀, back strain c p with c = α/(1-α). Where |e - c p| > ε_y the rest length flows
/// to L = (r + c L₀ ∓ ε_y L₀)/(1 + c), so that past yield a linear bond's tangent stiffness is α k
/// (α = 0: perfectly plastic). Unloaded after stretching to strain ε > ε_y, it keeps the permanent
/// set p = (1 - α)(ε - ε_y). The elastic energy the flow releases is charged as plastic work.
/// A bond whose |p| passes `max_plastic_strain` (the ductility limit) breaks.
struct PlasticRule {
  double yield_strain = 0;  ///< ε_y > 0
  double hardening = 0;     ///< α in [0, 1): tangent stiffness past yield over the elastic one
  double max_plastic_strain = std::numeric_limits<double>::infinity();
  /// Per quanta: 1 when selected; the rule applies to bonds with both ends selected (empty: all).
  std::vector<std::uint8_t> quanta{};
};

/// Rest length a bond flows to (PlasticRule), or L itself while within the yield surface.
double plastic_rest_length(const PlasticRule& rule, double r, double L, double L0);

std::unique_ptr<Heuristic> make_heuristic(BreakRule rule);
std::unique_ptr<Heuristic> make_heuristic(PlasticRule rule);

}  // namespace qbond
