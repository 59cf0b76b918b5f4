#include "qbond/laws/materials.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>

namespace qbond {
namespace {

// Voigt index of the pair (i, j).
int voigt(int i, int j) {
  if (i == j) return i;
  return 6 - i - j;  // (1,2) -> 3, (0,2) -> 4, (0,1) -> 5
}

double site_volume(const LatticeCell& cell, double a, double thickness) {
  if (!(a > 0)) throw std::invalid_argument("lattice spacing must be > 0");
  if (cell.dims == 2 && !(thickness > 0)) throw std::invalid_argument("a 2D lattice needs a thickness > 0");
  return cell.site_volume * a * a * (cell.dims == 2 ? thickness : a);
}

}  // namespace

ElasticConstants lattice_elastic_constants(const LatticeCell& cell, double k, double a, double thickness) {
  ElasticConstants e;
  const double V = site_volume(cell, a, thickness);
  for (const auto& o : cell.offsets) {
    const Vec3 d = cell.unit * a * Vec3(o[0], o[1], o[2]);
    const double L2 = d.squaredNorm();
    const Vec3 n = d / std::sqrt(L2);
    for (int i = 0; i < 3; ++i)
      for (int j = i; j < 3; ++j)
        for (int p = 0; p < 3; ++p)
          for (int q = p; q < 3; ++q) e.C(voigt(i, j), voigt(p, q)) += k * L2 * n[i] * n[j] * n[p] * n[q] / V;
  }
  // Uniaxial stress along x: invert the normal block of the lattice's dimensions (cubic symmetry
  // decouples shear from normal stress, so this is exact even when a lattice resists no shear).
  const int d = cell.dims;
  const Eigen::MatrixXd S = e.C.topLeftCorner(d, d).inverse();
  e.youngs_modulus = 1 / S(0, 0);
  e.poisson_ratio = -S(1, 0) / S(0, 0);
  e.shear_modulus = e.C(5, 5);
  return e;
}

double calibrated_stiffness(const LatticeCell& cell, double youngs_modulus, double a, double thickness) {
  return youngs_modulus / lattice_elastic_constants(cell, 1.0, a, thickness).youngs_modulus;
}

double calibrated_mass(const LatticeCell& cell, double density, double a, double thickness) {
  return density * site_volume(cell, a, thickness);
}

double series_stiffness(std::span<const double> k) {
  double compliance = 0;
  for (double ki : k) compliance += 1 / ki;
  return 1 / compliance;
}

double parallel_stiffness(std::span<const double> k) {
  double sum = 0;
  for (double ki : k) sum += ki;
  return sum;
}

ReducedChain reduce_chain(std::span<const double> k, std::span<const double> rest, std::span<const double> mass) {
  if (k.empty() || rest.size() != k.size() || mass.size() != k.size() + 1)
    throw std::invalid_argument("reduce_chain: need n bonds, n rest lengths and n + 1 masses");
  ReducedChain r;
  r.stiffness = series_stiffness(k);
  // Static shape under an end force F: u_i = F Σ_{b<i} 1/k_b, so u_i/u_end = k_eff Σ_{b<i} 1/k_b.
  double compliance = 0;
  for (std::size_t i = 1; i < mass.size(); ++i) {
    compliance += 1 / k[i - 1];
    const double shape = r.stiffness * compliance;
    r.end_mass += mass[i] * shape * shape;
    r.rest_length += rest[i - 1];
  }
  return r;
}

}  // namespace qbond
