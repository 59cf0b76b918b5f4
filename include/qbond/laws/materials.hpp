#pragma once
/// Materials from engineering constants: the elastic constants a central-force
/// lattice has, the bond stiffness and quanta mass that give it a Young's modulus and density,
/// and the paper's system reduction (Eqs. 14–15). docs/materials.md has the tables and limits.
#include <Eigen/Core>
#include <span>

#include "qbond/builders/builders.hpp"

namespace qbond {

/// Elastic constants of a lattice in its own axes, from the Cauchy–Born rule: under a uniform
/// strain every bond of a Bravais lattice stretches affinely (each site is a centre of symmetry,
/// so no internal relaxation), and the energy density gives
///     C_ijkl = (1/V_site) Σ_b k L_b² n_i n_j n_k n_l   over the site's bonds (half shells).
/// Central forces give Cauchy's relations (C12 = C44), which fix Poisson's ratio per lattice.
struct ElasticConstants {
  Eigen::Matrix<double, 6, 6> C = Eigen::Matrix<double, 6, 6>::Zero();  ///< Voigt: xx,yy,zz,yz,xz,xy [Pa]
  double youngs_modulus = 0;  ///< E along x under uniaxial stress [Pa] (2D: per thickness given)
  double poisson_ratio = 0;   ///< -ε_y/ε_x under uniaxial stress along x
  double shear_modulus = 0;   ///< C_xyxy [Pa]; 0 means the lattice resists no shear (not a solid)
};

/// The constants of `cell` with every bond of stiffness k [N/m], spacing a [m]; for a 2D cell
/// the sheet's `thickness` [m] turns its stiffness per length into a modulus.
ElasticConstants lattice_elastic_constants(const LatticeCell& cell, double k, double a, double thickness = 0);

/// The bond stiffness [N/m] that gives `cell` at spacing a the Young's modulus E along its axes
/// (E is linear in k: k = E / E(k = 1)).
double calibrated_stiffness(const LatticeCell& cell, double youngs_modulus, double a, double thickness = 0);

/// The mass [kg] of one quanta of `cell` at spacing a for a material of this density [kg/m³].
double calibrated_mass(const LatticeCell& cell, double density, double a, double thickness = 0);

/// Eq. 14: the stiffness of bonds in series, (Σ 1/k_i)⁻¹.
double series_stiffness(std::span<const double> k);
/// Eq. 15: the stiffness of bonds in parallel, Σ k_i.
double parallel_stiffness(std::span<const double> k);

/// A chain of series bonds reduced to one bond between its ends (Eq. 14). The static response
/// is exact; for the dynamics the chain's inner masses are lumped into the free end by
/// Rayleigh's rule (kinetic energy of the static deflection shape), which matches the lowest
/// mode as long as the chain is light next to what it carries.
struct ReducedChain {
  double stiffness = 0;  ///< Eq. 14 [N/m]
  double end_mass = 0;   ///< m_end + Σ m_i (u_i/u_end)², u the static shape from the fixed end [kg]
  double rest_length = 0;  ///< Σ L_i [m]
};
/// `k`, `rest` per bond (n); `mass` per quanta (n+1), the first is the fixed end.
ReducedChain reduce_chain(std::span<const double> k, std::span<const double> rest, std::span<const double> mass);

}  // namespace qbond
