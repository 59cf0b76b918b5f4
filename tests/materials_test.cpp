// Materials from engineering constants, the paper's system reduction (Eqs. 14-15), statics and
// stress: lattice elasticity against the closed forms, virial stress against Cauchy-Born, and
// calibrated blocks measured in a uniaxial test.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <string>

#include "qbond/laws/materials.hpp"
#include "qbond/io/scene.hpp"
#include "qbond/solvers/statics.hpp"
#include "qbond/analysis/stress.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

// Closed forms of central-force lattice elasticity (Cauchy–Born, all bonds of stiffness k):
// E along a cube axis = (C11 − C12)(C11 + 2 C12)/(C11 + C12), ν = C12/(C11 + C12), in units k/a.
struct Expected {
  const char* name;
  LatticeCell cell;
  double c11, c12, c44, E, nu;
};

TEST(Lattice, ElasticConstantsMatchTheClosedForms) {
  const double k = 3.0, a = 0.5;
  const Expected cases[] = {
      {"cubic nearest", cubic_cell(Shells::nearest), 1, 0, 0, 1, 0},
      {"cubic face", cubic_cell(Shells::face_diagonal), 3, 1, 1, 2.5, 0.25},
      {"cubic body", cubic_cell(Shells::body_diagonal), 13.0 / 3, 7.0 / 3, 7.0 / 3, 2.7, 0.35},
      {"fcc nearest", fcc_cell(false), 2, 1, 1, 4.0 / 3, 1.0 / 3},
      {"fcc second", fcc_cell(true), 6, 1, 1, 40.0 / 7, 1.0 / 7},
  };
  for (const Expected& c : cases) {
    SCOPED_TRACE(c.name);
    const ElasticConstants e = lattice_elastic_constants(c.cell, k, a);
    const double unit = k / a;
    EXPECT_NEAR(e.C(0, 0), c.c11 * unit, 1e-12 * unit);
    EXPECT_NEAR(e.C(0, 1), c.c12 * unit, 1e-12 * unit);
    EXPECT_NEAR(e.C(3, 3), c.c44 * unit, 1e-12 * unit);
    EXPECT_NEAR(e.C(2, 2), e.C(0, 0), 1e-12 * unit);  // cubic symmetry
    EXPECT_NEAR(e.youngs_modulus, c.E * unit, 1e-12 * unit);
    EXPECT_NEAR(e.poisson_ratio, c.nu, 1e-12);
    EXPECT_NEAR(e.shear_modulus, c.c44 * unit, 1e-12 * unit);
  }
  // 2D square with diagonals, a sheet of thickness t: C11 = 2k/t, C12 = C66 = k/t, plane stress
  // E = (C11² − C12²)/C11 = 1.5 k/t, ν = 1/2.
  const double t = 0.2;
  const ElasticConstants s = lattice_elastic_constants(square_cell(true, false), k, a, t);
  EXPECT_NEAR(s.youngs_modulus, 1.5 * k / t, 1e-12 * k / t);
  EXPECT_NEAR(s.poisson_ratio, 0.5, 1e-12);
  EXPECT_NEAR(s.shear_modulus, k / t, 1e-12 * k / t);
  // Calibration inverts it: the stiffness for E gives back E.
  const double E = 200e9;
  for (const Expected& c : cases)
    EXPECT_NEAR(lattice_elastic_constants(c.cell, calibrated_stiffness(c.cell, E, a), a).youngs_modulus, E, 1e-12 * E);
  EXPECT_DOUBLE_EQ(calibrated_mass(fcc_cell(false), 7850, a), 7850 * a * a * a / 4);
}

// Under a uniform strain ε every bond of a Bravais lattice stretches affinely, so the virial
// stress of an interior quanta is exactly C : ε (to first order in ε; checked at ε ~ 1e-7 where
// the quadratic terms are below the tolerance).
TEST(Stress, VirialOfAnInteriorQuantaIsTheCauchyBornStress) {
  const double k = 10, a = 0.01;
  Mat3 eps;
  eps << 1.0, 0.3, -0.2, 0.3, -0.5, 0.4, -0.2, 0.4, 0.7;
  eps *= 1e-7;
  auto voigt = [](const Mat3& m, bool strain) {
    const double f = strain ? 2 : 1;
    Eigen::Matrix<double, 6, 1> v;
    v << m(0, 0), m(1, 1), m(2, 2), f * m(1, 2), f * m(0, 2), f * m(0, 1);
    return v;
  };
  for (bool fcc : {false, true}) {
    SCOPED_TRACE(fcc ? "fcc" : "cubic");
    World w;
    const LatticeCell cell = fcc ? fcc_cell(true) : cubic_cell(Shells::body_diagonal);
    std::vector<Index> ids;
    if (fcc) {
      ids = add_fcc_lattice(w, {.cells = {4, 4, 4}, .spacing = a, .second_shell = true, .bond = {.stiffness = k}});
    } else {
      CubicLattice l;
      l.size = {5, 5, 5};
      l.spacing = a;
      l.shells = Shells::body_diagonal;
      l.bond = {.stiffness = k};
      ids = add_cubic_lattice(w, l);
    }
    const Vec3 centre(2 * a, 2 * a, 2 * a);
    Index mid = 0;
    for (Index i : ids)
      if ((w.state.x[i] - centre).norm() < 1e-9) mid = i;
    ASSERT_LT((w.state.x[mid] - centre).norm(), 1e-9);
    for (Vec3& x : w.state.x) x += eps * x;
    std::vector<Mat3> sigma;
    virial_stress(w.model, w.state, sigma);
    const Eigen::Matrix<double, 6, 1> expected = lattice_elastic_constants(cell, k, a).C * voigt(eps, true);
    const Eigen::Matrix<double, 6, 1> got = voigt(sigma[mid], false);
    const double scale = expected.cwiseAbs().maxCoeff();
    for (int c = 0; c < 6; ++c) EXPECT_NEAR(got[c], expected[c], 1e-6 * scale) << "component " << c;
  }
}

TEST(Stress, VonMisesOfTheStandardStates) {
  const double s = 7.0;
  EXPECT_NEAR(von_mises(s * Mat3(Vec3(1, 0, 0).asDiagonal())), s, 1e-12);  // uniaxial: σ
  Mat3 shear = Mat3::Zero();
  shear(0, 1) = shear(1, 0) = s;
  EXPECT_NEAR(von_mises(shear), std::sqrt(3.0) * s, 1e-12);  // pure shear: √3 τ
  EXPECT_NEAR(von_mises(s * Mat3::Identity()), 0, 1e-12);    // hydrostatic: 0
}

// One bond of tension T between two quanta of volume V: each gets T r/(2V) n nᵀ.
TEST(Stress, OneBondGivesHalfItsVirialToEachEnd) {
  World w = test::two_quanta(1, 50, 1.0, 0.1, 0);
  w.model.volume = {2.0, 4.0};
  std::vector<Mat3> sigma;
  virial_stress(w.model, w.state, sigma);
  const double T = 50 * 0.1, r = 1.1;
  EXPECT_NEAR(sigma[0](0, 0), T * r / (2 * 2.0), 1e-12);
  EXPECT_NEAR(sigma[1](0, 0), T * r / (2 * 4.0), 1e-12);
  EXPECT_NEAR(sigma[0].norm() - std::abs(sigma[0](0, 0)), 0, 1e-12);
}

// A uniaxial tensile test of a block built from a scene's engineering constants: the x = 0 face
// anchored, the far face pulled with total force σ₀ A. In the bulk (away from the clamped and
// loaded ends and the free surfaces) σ_xx/ε_xx is the material's E.
struct Uniaxial {
  double E_bulk;          // σ_xx / ε_xx in the bulk
  double E_hooke;         // (σ_xx − ν (σ_yy + σ_zz)) / ε_xx: the same without the small lateral stress
  double lateral_stress;  // max(|σ_yy|, |σ_zz|) / σ_xx in the bulk
  double mass, expected_mass;
};
Uniaxial uniaxial_test(double E, double density, double a, int n, double strain) {
  const int nx = 3 * n;
  const double L = (nx - 1) * a, side = n * a;
  auto s = [](double v) {
    char b[40];
    std::snprintf(b, sizeof b, "%.17g", v);
    return std::string(b);
  };
  const double force = strain * E * side * side;
  const std::string json = R"({"timestep": 1e-4, "steps": 1,
    "materials": {"m": {"youngs_modulus": )" + s(E) + R"(, "density": )" + s(density) + R"(}},
    "bodies": [{"name": "block", "type": "lattice", "cell": "cubic", "neighbors": "face_diagonal",
                "size": [)" + std::to_string(nx) + "," + std::to_string(n) + "," + std::to_string(n) +
                           R"(], "spacing": )" + s(a) + R"(, "material": "m"}],
    "anchors": [{"select": {"box": [[-1, -1, -1], [)" + s(0.5 * a) + R"(, 1e3, 1e3]]}}],
    "loads": [{"select": {"box": [[)" + s(L - 0.5 * a) + R"(, -1, -1], [1e3, 1e3, 1e3]]}, "force": [)" +
                           s(force) + R"(, 0, 0]}]})";
  Scene scene = parse_scene(json, "uniaxial");
  World& w = scene.world;
  const std::vector<Vec3> x0 = w.state.x;
  const StaticResult r = solve_static(w, 1e-8);
  EXPECT_TRUE(r.converged) << r.residual;
  std::vector<Mat3> sigma;
  virial_stress(w.model, w.state, sigma);
  // The bulk: the middle third along x, two layers in from every free surface.
  std::vector<Index> bulk, left, right;
  const int x1 = n, x2 = 2 * n - 1;
  double mass = 0;
  for (std::size_t i = 0; i < w.num_quanta(); ++i) {
    mass += w.model.mass[i];
    const Vec3 g = x0[i] / a;
    const int X = static_cast<int>(std::lround(g.x())), Y = static_cast<int>(std::lround(g.y())),
              Z = static_cast<int>(std::lround(g.z()));
    if (Y < 2 || Z < 2 || Y > n - 3 || Z > n - 3 || X < x1 || X > x2) continue;
    bulk.push_back(static_cast<Index>(i));
    if (X == x1) left.push_back(static_cast<Index>(i));
    if (X == x2) right.push_back(static_cast<Index>(i));
  }
  auto mean_ux = [&](const std::vector<Index>& q) {
    double u = 0;
    for (Index i : q) u += w.state.x[i].x() - x0[i].x();
    return u / static_cast<double>(q.size());
  };
  const double eps_xx = (mean_ux(right) - mean_ux(left)) / ((x2 - x1) * a);
  const Mat3 s_bulk = mean_stress(w.model, sigma, bulk);
  return {s_bulk(0, 0) / eps_xx, (s_bulk(0, 0) - 0.25 * (s_bulk(1, 1) + s_bulk(2, 2))) / eps_xx, std::max(std::abs(s_bulk(1, 1)), std::abs(s_bulk(2, 2))) / s_bulk(0, 0), mass,
          density * nx * n * n * a * a * a};
}

TEST(Calibration, SteelAndRubberBlocksHaveTheirYoungsModulusInTheBulk) {
  struct Case {
    const char* name;
    double E, density, a;
  };
  for (const Case& c : {Case{"steel 200 GPa", 200e9, 7850, 1e-3}, Case{"rubber 1 MPa", 1e6, 1100, 5e-3}}) {
    SCOPED_TRACE(c.name);
    const Uniaxial u = uniaxial_test(c.E, c.density, c.a, 8, 1e-5);
    EXPECT_NEAR(u.E_bulk / c.E, 1.0, 0.03);
    EXPECT_LT(std::abs(u.lateral_stress), 0.03);  // the bulk is in uniaxial stress
    EXPECT_NEAR(u.mass / u.expected_mass, 1.0, 1e-12);
    EXPECT_NEAR(u.E_hooke / c.E, 1.0, 0.005);
    std::printf("%s: E_bulk / E = %.5f, with the lateral stress %.5f, lateral/axial stress = %.2e\n", c.name,
                u.E_bulk / c.E, u.E_hooke / c.E, u.lateral_stress);
  }
}

// Coarsening (system reduction of a lattice): the same material at twice the spacing has bonds
// twice as stiff and quanta eight times heavier, and the same bulk modulus and density.
TEST(Calibration, CoarseningKeepsTheBulkStiffness) {
  const double E = 70e9;
  const LatticeCell cell = cubic_cell(Shells::face_diagonal);
  EXPECT_NEAR(calibrated_stiffness(cell, E, 2e-3) / calibrated_stiffness(cell, E, 1e-3), 2.0, 1e-12);
  EXPECT_NEAR(calibrated_mass(cell, 2700, 2e-3) / calibrated_mass(cell, 2700, 1e-3), 8.0, 1e-12);
  const Uniaxial fine = uniaxial_test(E, 2700, 1e-3, 10, 1e-5);
  const Uniaxial coarse = uniaxial_test(E, 2700, 2e-3, 6, 1e-5);
  EXPECT_NEAR(fine.E_bulk / E, 1.0, 0.03);
  EXPECT_NEAR(coarse.E_bulk / E, 1.0, 0.03);
  std::printf("E_bulk / E: spacing a %.5f, spacing 2a %.5f\n", fine.E_bulk / E, coarse.E_bulk / E);
}

// Eq. 14: bonds in series. A chain anchored at one end and pulled by F at the other stretches
// F/k_eff, exactly as the one bond that replaces it; Eq. 15: bonds side by side between the same
// two quanta act as one bond of Σ k.
World series_chain(const std::vector<double>& k, double quanta_mass, double end_mass, double F) {
  World w;
  w.add_quanta(Vec3::Zero(), Vec3::Zero(), 0);
  double x = 0;
  for (std::size_t b = 0; b < k.size(); ++b) {
    x += 0.1 * static_cast<double>(b + 1);
    w.add_quanta(Vec3(x, 0, 0), Vec3::Zero(), b + 1 == k.size() ? end_mass : quanta_mass);
    w.add_bond(static_cast<Index>(b), static_cast<Index>(b + 1), {.stiffness = k[b]});
  }
  w.add_load({static_cast<Index>(k.size())}, Vec3(F, 0, 0));
  return w;
}

World one_bond(double k, double L, double end_mass, double F) {
  World w;
  w.add_quanta(Vec3::Zero(), Vec3::Zero(), 0);
  w.add_quanta(Vec3(L, 0, 0), Vec3::Zero(), end_mass);
  w.add_bond(0, 1, {.stiffness = k});
  w.add_load({1}, Vec3(F, 0, 0));
  return w;
}

const std::vector<double> kChain = {100, 250, 40, 900, 75};

TEST(Reduction, SeriesAndParallelBondsHaveTheStaticResponseOfOneBond) {
  const double F = 0.7;
  const double k_series = series_stiffness(kChain);
  EXPECT_NEAR(k_series, 1 / (1 / 100.0 + 1 / 250.0 + 1 / 40.0 + 1 / 900.0 + 1 / 75.0), 1e-12);
  World chain = series_chain(kChain, 1e-3, 1, F);
  const double L = chain.state.x.back().x();
  ASSERT_TRUE(solve_static(chain, 1e-12).converged);
  World reduced = one_bond(k_series, L, 1, F);
  ASSERT_TRUE(solve_static(reduced, 1e-12).converged);
  EXPECT_NEAR(chain.state.x.back().x() - L, F / k_series, 1e-13);
  EXPECT_NEAR(reduced.state.x.back().x() - L, F / k_series, 1e-13);

  World bundle;
  bundle.add_quanta(Vec3::Zero(), Vec3::Zero(), 0);
  bundle.add_quanta(Vec3(0.3, 0, 0), Vec3::Zero(), 1);
  for (double kb : kChain) bundle.add_bond(0, 1, {.stiffness = kb});
  bundle.add_load({1}, Vec3(F, 0, 0));
  ASSERT_TRUE(solve_static(bundle, 1e-12).converged);
  EXPECT_DOUBLE_EQ(parallel_stiffness(kChain), 1365.0);
  EXPECT_NEAR(bundle.state.x[1].x() - 0.3, F / 1365.0, 1e-15);
}

// Low frequencies: a light chain carrying a heavy end mass, reduced to one bond whose end mass
// takes in the chain's masses by Rayleigh's rule. The lowest mode's frequency agrees to second
// order in (chain mass / end mass); a free vibration agrees over several periods.
TEST(Reduction, SeriesChainMatchesTheLowFrequencyDynamics) {
  const double m = 1e-3, M = 1.0, F = 0.05;
  World chain = series_chain(kChain, m, M, F);
  std::vector<double> rest, mass = {0};
  for (std::size_t b = 0; b < kChain.size(); ++b) {
    rest.push_back(chain.state.bonds.rest[b]);
    mass.push_back(chain.model.mass[b + 1]);
  }
  const ReducedChain red = reduce_chain(kChain, rest, mass);
  EXPECT_GT(red.end_mass, M);
  EXPECT_LT(red.end_mass, M + 4 * m);

  // Lowest axial mode of the full chain: K u = ω² M u on the x coordinates.
  const std::size_t n = kChain.size();
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n, n), Mm = Eigen::MatrixXd::Zero(n, n);
  for (std::size_t b = 0; b < n; ++b) {
    K(b, b) += kChain[b];
    if (b > 0) {
      K(b - 1, b - 1) += kChain[b];
      K(b - 1, b) -= kChain[b];
      K(b, b - 1) -= kChain[b];
    }
    Mm(b, b) = mass[b + 1];
  }
  const double w_full = std::sqrt(Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd>(K, Mm).eigenvalues()[0]);
  const double w_red = std::sqrt(red.stiffness / red.end_mass);
  const double w_plain = std::sqrt(red.stiffness / M);  // the end mass alone, chain ignored
  EXPECT_NEAR(w_red / w_full, 1.0, 1e-5);
  EXPECT_GT(std::abs(w_plain / w_full - 1), 10 * std::abs(w_red / w_full - 1));

  // Free vibration from the loaded equilibrium, both with the same small-step integrator.
  const double L = chain.state.x.back().x();
  ASSERT_TRUE(solve_static(chain, 1e-12).converged);
  chain.model.loads.clear();
  World reduced = one_bond(red.stiffness, L, red.end_mass, F);
  ASSERT_TRUE(solve_static(reduced, 1e-12).converged);
  reduced.model.loads.clear();
  const double h = 1e-4, amplitude = F / red.stiffness;
  Simulation full_sim(std::move(chain), test::coupled(CoupledSolver::ldlt), h);
  Simulation red_sim(std::move(reduced), test::coupled(CoupledSolver::ldlt), h);
  const int steps = static_cast<int>(3 * 2 * M_PI / w_full / h);
  double worst = 0;
  for (int s = 0; s < steps; ++s) {
    full_sim.step();
    red_sim.step();
    worst = std::max(worst, std::abs(full_sim.world().state.x.back().x() - red_sim.world().state.x.back().x()));
  }
  EXPECT_LT(worst, 0.01 * amplitude);
}

}  // namespace
}  // namespace qbond
