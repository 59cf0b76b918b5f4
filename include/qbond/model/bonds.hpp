#pragma once
/// The bonds as structure of arrays: everything about them a run may change (formation makes
/// them, fracture breaks them, plasticity moves their rest lengths), so they live in the State
/// and a checkpoint or a rollback carries them whole.
#include <cstdint>
#include <limits>
#include <vector>

#include "qbond/core/math.hpp"
#include "qbond/laws/laws.hpp"

namespace qbond {

/// One bond's law and parameters as the bonds store them (its shape a row of Model::shapes).
struct BondLaw {
  Law law = Law::linear;
  DampingModel damping_model = DampingModel::axial;
  double strength = 0;      ///< the law's per-bond parameter (LawInfo::strength)
  double damping = 0;       ///< D [N·s/m]
  std::uint32_t shape = 0;  ///< its row of Model::shapes
};

/// Every bond, alive or broken (nb entries in each array). Kernels stream these arrays; the law
/// helpers take the model's table of shape parameters, which the bonds index as LAMMPS's bonds
/// index their bond type's coefficients.
struct Bonds {
  std::vector<Index> i, j;  ///< endpoints
  std::vector<Index> id;    ///< the user's id (creation order, or the formed slot), kept by renumbering
  std::vector<Law> law;
  std::vector<DampingModel> damping_model;
  /// The strength of the bond's law, its per-bond parameter (LawInfo::strength): k [N/m] for
  /// linear, F [N] for inverse, D0 [J] for morse, K [N/m] for fene, k [N/m] for cohesive.
  std::vector<double> strength;
  std::vector<double> damping;        ///< D [N·s/m]
  std::vector<double> rest0;          ///< rest length the bond was made with [m]; plastic strain is measured from it
  std::vector<std::uint32_t> shape;   ///< its row of Model::shapes: the law's shape parameters
  std::vector<double> rest;           ///< current rest length L [m]; plasticity edits it
  std::vector<std::uint8_t> alive;    ///< 1 while the bond holds
  /// [s] when the bond was last made or broken (0 for the scene's until they break)
  std::vector<double> time;
  /// Bonds [first_formed, size()) were made during the run (formation); their slots are reused
  /// once broken. The scene's bonds come first.
  std::size_t first_formed = 0;

  std::size_t size() const { return i.size(); }
  /// Bond b's law and parameters.
  BondLaw law_of(std::size_t b) const { return {law[b], damping_model[b], strength[b], damping[b], shape[b]}; }

  /// What bond b's law reads besides the lengths.
  [[gnu::always_inline]] LawArgs law_args(const std::vector<LawShape>& shapes, std::size_t b) const {
    return {strength[b], rest0[b], shapes[shape[b]]};
  }
  /// Bond b's law at length r for rest length L (a linear bond reads no shape).
  [[gnu::always_inline]] LawValue law_at(const std::vector<LawShape>& shapes, std::size_t b, double r,
                                         double L) const {
    if (law[b] == Law::linear) return LinearLaw::eval(r, L, {.strength = strength[b]});
    return evaluate_law(law[b], r, L, law_args(shapes, b));
  }
  /// Bond b's mean tension over a step from length r0 to r1 (MeanTension).
  [[gnu::always_inline]] MeanTension mean_tension_at(const std::vector<LawShape>& shapes, std::size_t b,
                                                     double r0, double r1, double L) const {
    if (law[b] == Law::linear) return LinearLaw::mean(r0, r1, L, {.strength = strength[b]});
    return mean_tension(law[b], r0, r1, L, law_args(shapes, b));
  }
  /// Bond b's force on its first quanta (laws.hpp's bond_force_on_i): d = x_j − x_i, w = v_j − v_i.
  [[gnu::always_inline]] Vec3 force_on_i(const std::vector<LawShape>& shapes, std::size_t b, const Vec3& d,
                                         const Vec3& w, double L) const {
    const LawArgs a = law[b] == Law::linear ? LawArgs{.strength = strength[b]} : law_args(shapes, b);
    return bond_force_on_i(law[b], damping_model[b], d, w, L, damping[b], a);
  }
  /// Stretch r − L at which bond b's law breaks it (+∞: never).
  double failure_stretch_at(const std::vector<LawShape>& shapes, std::size_t b, double L) const {
    return law_breaks(law[b]) ? failure_stretch(law[b], L, law_args(shapes, b))
                              : std::numeric_limits<double>::infinity();
  }

  bool operator==(const Bonds&) const = default;  ///< array by array (tests, rollbacks)
};

}  // namespace qbond
