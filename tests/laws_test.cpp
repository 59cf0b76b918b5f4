// Force laws: finite-difference checks of every law's tension, force, stiffness and damping
// blocks, U' = T, and Newton's third law.
#include <gtest/gtest.h>

#include <vector>

#include "integrators/bond_forces.hpp"
#include "qbond/laws/laws.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

constexpr double kTol = 1e-6;  // relative-error bound of the finite-difference checks

struct LawCase {
  Law law;
  double L, strength, eps;
};

std::vector<LawCase> law_cases() {
  return {{Law::linear, 1.0, 250.0, 0.05}, {Law::inverse, 1.0, 3.0, 0.05}, {Law::inverse, 0.02, 0.7, 0.001}};
}

// Lengths around the rest length, in compression and tension, on both sides of the inverse law's
// peak at |r - L| = eps.
std::vector<double> lengths(const LawCase& c) {
  std::vector<double> r;
  for (double s : {-0.5, -3.0, -1.0, -0.3, 0.2, 1.0, 2.5, 8.0}) r.push_back(c.L + s * c.eps);
  return r;
}

TEST(Laws, PotentialDerivativeIsTension) {
  for (const LawCase& c : law_cases())
    for (double r : lengths(c)) {
      // Relative errors are taken against the law's own scale where a value crosses zero
      // (T' vanishes at the inverse law's peak): the stiffness at rest, and that times eps.
      const double k0 = evaluate_law(c.law, c.L, c.L, c.strength, c.eps).dT;
      const double d = 1e-4 * c.eps;  // central difference: truncation O(d²), round-off O(ε U / d)
      const double dU = (evaluate_law(c.law, r + d, c.L, c.strength, c.eps).U -
                         evaluate_law(c.law, r - d, c.L, c.strength, c.eps).U) / (2 * d);
      const LawValue lv = evaluate_law(c.law, r, c.L, c.strength, c.eps);
      EXPECT_NEAR(dU, lv.T, kTol * std::max(std::abs(lv.T), k0 * c.eps)) << to_string(c.law) << " r=" << r;
      const double dT = (evaluate_law(c.law, r + d, c.L, c.strength, c.eps).T -
                         evaluate_law(c.law, r - d, c.L, c.strength, c.eps).T) / (2 * d);
      EXPECT_NEAR(dT, lv.dT, kTol * std::max(std::abs(lv.dT), k0)) << to_string(c.law) << " r=" << r;
    }
}

TEST(Laws, InverseLawShape) {
  // Slope F/eps² at rest, peak F/(2 eps) at |r - L| = eps, and Eq. 3's F/(r - L) far away.
  const double F = 2.0, L = 1.0, eps = 0.01;
  EXPECT_DOUBLE_EQ(evaluate_law(Law::inverse, L, L, F, eps).dT, F / (eps * eps));
  EXPECT_DOUBLE_EQ(evaluate_law(Law::inverse, L + eps, L, F, eps).T, F / (2 * eps));
  EXPECT_NEAR(evaluate_law(Law::inverse, L + eps, L, F, eps).dT, 0.0, 1e-9);
  const double far = 100 * eps;
  EXPECT_NEAR(evaluate_law(Law::inverse, L + far, L, F, eps).T, F / far, 1e-4 * F / far);
}

// The force on quanta i as a function of both ends' positions and velocities.
Vec3 force_i(const LawCase& c, DampingModel dm, double D, const Vec3& xi, const Vec3& xj, const Vec3& vi,
             const Vec3& vj) {
  return bond_force_on_i(c.law, dm, xj - xi, vj - vi, c.L, c.strength, D, c.eps);
}

TEST(Laws, StiffnessAndDampingBlocksMatchFiniteDifferences) {
  Rng rng{3};
  auto rnd = [&] { return Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5); };
  for (const LawCase& c : law_cases())
    for (DampingModel dm : {DampingModel::axial, DampingModel::isotropic})
      for (double r : lengths(c)) {
        const double D = 0.3;
        const Vec3 xi = rnd(), vi = rnd(), vj = rnd();
        const Vec3 u = rnd().normalized();
        const Vec3 xj = xi + r * u;
        const LawValue lv = evaluate_law(c.law, r, c.L, c.strength, c.eps);
        const Mat3 K = stiffness_block(lv.T, lv.dT, r, u, /*clamp_for_solver=*/false);
        const Mat3 C = damping_block(dm, D, u);
        Mat3 dfi_dxj, dfi_dxi, dfi_dvj, dfi_dvi;
        const double hx = 1e-4 * c.eps, hv = 1e-3;
        for (int a = 0; a < 3; ++a) {
          const Vec3 e = Vec3::Unit(a);
          dfi_dxj.col(a) = (force_i(c, dm, D, xi, xj + hx * e, vi, vj) - force_i(c, dm, D, xi, xj - hx * e, vi, vj)) / (2 * hx);
          dfi_dxi.col(a) = (force_i(c, dm, D, xi + hx * e, xj, vi, vj) - force_i(c, dm, D, xi - hx * e, xj, vi, vj)) / (2 * hx);
          dfi_dvj.col(a) = (force_i(c, dm, D, xi, xj, vi, vj + hv * e) - force_i(c, dm, D, xi, xj, vi, vj - hv * e)) / (2 * hv);
          dfi_dvi.col(a) = (force_i(c, dm, D, xi, xj, vi + hv * e, vj) - force_i(c, dm, D, xi, xj, vi - hv * e, vj)) / (2 * hv);
        }
        // The damping force of the axial model turns with u, so it adds d(D (w·u) u)/dx to the
        // position Jacobian; K_b is the elastic part only. Remove it by differencing at w = 0.
        if (dm == DampingModel::axial) {
          for (int a = 0; a < 3; ++a) {
            const Vec3 e = Vec3::Unit(a);
            dfi_dxj.col(a) = (force_i(c, dm, D, xi, xj + hx * e, vi, vi) - force_i(c, dm, D, xi, xj - hx * e, vi, vi)) / (2 * hx);
            dfi_dxi.col(a) = (force_i(c, dm, D, xi + hx * e, xj, vi, vi) - force_i(c, dm, D, xi - hx * e, xj, vi, vi)) / (2 * hx);
          }
        }
        const double kn = K.norm(), cn = C.norm();
        EXPECT_LE((dfi_dxj - K).norm(), kTol * kn) << to_string(c.law) << " r=" << r;
        EXPECT_LE((dfi_dxi + K).norm(), kTol * kn) << to_string(c.law) << " r=" << r;
        EXPECT_LE((dfi_dvj - C).norm(), kTol * cn) << to_string(dm);
        EXPECT_LE((dfi_dvi + C).norm(), kTol * cn) << to_string(dm);
      }
}

TEST(Laws, IsotropicDampingIsEquationTwoLiterally) {
  // Eq. 2's damping term on A is -D (v_A - v_B): the relative velocity, not only its axial part.
  const Vec3 d(1, 0, 0), w(0.2, -0.4, 0.7);
  const Vec3 f = bond_force_on_i(Law::linear, DampingModel::isotropic, d, w, 1.0, 10.0, 0.5, 0.05);
  EXPECT_EQ(f, Vec3(0.5 * w));
  const Vec3 fa = bond_force_on_i(Law::linear, DampingModel::axial, d, w, 1.0, 10.0, 0.5, 0.05);
  EXPECT_EQ(fa, Vec3(0.5 * 0.2, 0, 0));
}

TEST(Laws, ClampedBlockIsPositiveSemiDefinite) {
  const Vec3 u = Vec3(1, 2, 3).normalized();
  // Compressed linear bond: T < 0 makes the transverse term negative.
  const LawValue lv = evaluate_law(Law::linear, 0.8, 1.0, 100.0, 0.05);
  const Mat3 exact = stiffness_block(lv.T, lv.dT, 0.8, u, false);
  const Mat3 clamped = stiffness_block(lv.T, lv.dT, 0.8, u, true);
  EXPECT_LT(Eigen::SelfAdjointEigenSolver<Mat3>(exact).eigenvalues().minCoeff(), 0.0);
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Mat3>(clamped).eigenvalues().minCoeff(), -1e-12);
  EXPECT_NEAR((clamped * u - exact * u).norm(), 0.0, 1e-12);  // the axial stiffness is kept
}

TEST(Laws, ZeroLengthBondExertsNoForce) {
  const Vec3 f = bond_force_on_i(Law::linear, DampingModel::axial, Vec3::Zero(), Vec3(1, 0, 0), 1.0, 10, 1, 0.05);
  EXPECT_EQ(f, Vec3::Zero());
}

TEST(Laws, NewtonsThirdLawHoldsExactly) {
  // Summed over a perturbed, damped lattice the bond forces cancel to the last bit per bond pair,
  // so their total is zero up to the round-off of the summation itself.
  for (Law law : {Law::linear, Law::inverse}) {
    World w = test::lattice(3, 3, 3, 500, 1e-3, 0.2, false, Vec3::Zero(), law);
    test::perturb(w, 1e-3, 0.1);
    const std::vector<Vec3> none(w.num_quanta(), Vec3::Zero());
    std::vector<Vec3> f;
    Adjacency adj;
    build_adjacency(w.model, w.state, adj);
    BondPartition part;
    part.update(w.model, adj, 1);
    ForceArrays work;
    bond_force_sums(w.model, w.state, part, w.state.x, w.state.v, none, 1, work, f);
    Vec3 sum = Vec3::Zero();
    double scale = 0;
    for (const Vec3& fi : f) {
      sum += fi;
      scale += fi.norm();
    }
    EXPECT_LE(sum.norm(), 1e-14 * scale) << to_string(law);
  }
}

}  // namespace
}  // namespace qbond
