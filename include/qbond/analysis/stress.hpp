#pragma once
/// Stress (docs/materials.md): the per-quanta virial stress tensor and its von Mises equivalent.
#include <span>
#include <vector>

#include "qbond/model/world.hpp"

namespace qbond {

/// Virial (Cauchy) stress of every quanta [Pa], tension positive:
///     σ_i = 1/(2 V_i) Σ_b sym(d_b ⊗ f_b),   d_b = x_j − x_i,  f_b = the bond's force on i,
/// over i's alive bonds (law plus damping), at positions x and velocities v. Each bond gives half
/// of its virial to each end, so in a uniformly strained lattice σ_i is exactly the Cauchy–Born
/// stress of materials.hpp. Quanta of unknown volume (Model::volume 0) get 0. Surface quanta
/// miss the neighbours outside and read low (as LAMMPS' per-atom stress does).
void virial_stress(const Model& model, const State& state, const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                   std::vector<Mat3>& sigma);
/// The same at the state's own positions and velocities.
void virial_stress(const Model& model, const State& state, std::vector<Mat3>& sigma);

/// Von Mises equivalent stress √(3/2 s:s), s the deviator of σ [Pa].
double von_mises(const Mat3& sigma);

/// Σ V_i σ_i / Σ V_i over `quanta`: the mean stress of a region [Pa] (0 when no volume is known).
Mat3 mean_stress(const Model& model, std::span<const Mat3> sigma, std::span<const Index> quanta);

}  // namespace qbond
