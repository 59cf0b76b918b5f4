// Integrators against exact solutions: convergence orders, backward Euler's amplification,
// hybrid vs coupled, and agreement of the coupled solvers.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <tuple>

#include "integrators/bond_partition.hpp"
#include "integrators/bond_forces.hpp"
#include "integrators/backward_euler.hpp"
#include "integrators/integrator_common.hpp"
#include "qbond/io/checkpoint.hpp"
#include "qbond/heuristics/fracture.hpp"
#include "qbond/model/ordering.hpp"
#include "qbond/builders/samples.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

using test::coupled;
using test::hybrid;

// Error of quanta 1's position at time T against the exact solution of the two-quanta system
// (relative coordinate s = r - L, centre of mass still): with reduced mass m/2 and bond damping D,
// s'' + 2ζω s' + ω² s = 0, ω = sqrt(2k/m) = 1, ζ = D/m; undamped s(t) = s0 cos ωt + (w0/ω) sin ωt.
double harmonic_error(IntegratorType type, double h, double T, double D = 0) {
  const double m = 1.0, k = 0.5, L = 1.0, s0 = 0.1, w0 = 0.05;
  Simulation sim(test::two_quanta(m, k, L, s0, w0, D), test::config(type), h);
  const auto steps = static_cast<int>(std::lround(T / h));
  for (int i = 0; i < steps; ++i) sim.step();
  const double omega = std::sqrt(2 * k / m), zeta = D / m, t = steps * h;
  const double wd = omega * std::sqrt(1 - zeta * zeta);
  const double s = std::exp(-zeta * omega * t) *
                   (s0 * std::cos(wd * t) + (w0 + zeta * omega * s0) / wd * std::sin(wd * t));
  const Vec3 exact(0.5 * (L + s0) + 0.5 * (L + s), 0, 0);  // x_1 = centre + (L + s)/2
  return (sim.world().state.x[1] - exact).norm();
}

struct OrderCase {
  IntegratorType type;
  double order, h0;
};

class ExplicitOrder : public testing::TestWithParam<OrderCase> {};

TEST_P(ExplicitOrder, ObservedOrderFromHalvingH) {
  const OrderCase c = GetParam();
  const double T = 2.0;
  const double e1 = harmonic_error(c.type, c.h0, T), e2 = harmonic_error(c.type, c.h0 / 2, T),
               e3 = harmonic_error(c.type, c.h0 / 4, T);
  const double p1 = std::log2(e1 / e2), p2 = std::log2(e2 / e3);
  RecordProperty("observed_order", std::to_string(p2));
  EXPECT_NEAR(p1, c.order, 0.25) << to_string(c.type) << " errors " << e1 << " " << e2;
  EXPECT_NEAR(p2, c.order, 0.25) << to_string(c.type) << " errors " << e2 << " " << e3;
}

// The same with damping (ζ = 0.2): the forces depend on the velocity, which velocity Verlet
// evaluates at a predicted one (Groot–Warren), and RK4 at its stages.
TEST_P(ExplicitOrder, ObservedOrderWithDamping) {
  const OrderCase c = GetParam();
  const double T = 2.0, D = 0.2;
  const double e1 = harmonic_error(c.type, c.h0, T, D), e2 = harmonic_error(c.type, c.h0 / 2, T, D),
               e3 = harmonic_error(c.type, c.h0 / 4, T, D);
  EXPECT_NEAR(std::log2(e1 / e2), c.order, 0.25) << to_string(c.type) << " errors " << e1 << " " << e2;
  EXPECT_NEAR(std::log2(e2 / e3), c.order, 0.25) << to_string(c.type) << " errors " << e2 << " " << e3;
}

INSTANTIATE_TEST_SUITE_P(Integrators, ExplicitOrder,
                         testing::Values(OrderCase{IntegratorType::explicit_euler, 1, 0.01},
                                         OrderCase{IntegratorType::symplectic_euler, 1, 0.01},
                                         OrderCase{IntegratorType::velocity_verlet, 2, 0.02},
                                         OrderCase{IntegratorType::rk4, 4, 0.1}),
                         [](const auto& info) { return std::string(to_string(info.param.type)); });

// Backward Euler on x'' = -ω² x maps (ω s, v) by a rotation scaled by 1/sqrt(1 + (hω)²) per step.
// The linearised coupled step is exact on a linear bond moving along its axis.
TEST(CoupledImplicit, MatchesBackwardEulerAmplification) {
  const double m = 2.0, k = 50.0, L = 1.0;
  const double omega = std::sqrt(2 * k / m);
  for (CoupledSolver solver : {CoupledSolver::dense, CoupledSolver::ldlt, CoupledSolver::cg})
    for (double homega : {0.1, 1.0, 10.0}) {
      const double h = homega / omega;
      Simulation sim(test::two_quanta(m, k, L, 0.1, 0.3), coupled(solver, 1e-15), h);
      auto amplitude = [&] {
        const State& s = sim.world().state;
        const double sr = (s.x[1] - s.x[0]).norm() - L;
        const double vr = (s.v[1] - s.v[0]).x();
        return std::hypot(omega * sr, vr);
      };
      const double expected = 1.0 / std::sqrt(1.0 + homega * homega);
      for (int n = 0; n < 3; ++n) {
        const double a0 = amplitude();
        sim.step();
        EXPECT_NEAR(amplitude() / a0, expected, 1e-9 * expected)
            << to_string(solver) << " hω=" << homega << " step " << n;
      }
    }
}

// A single free quanta bonded to anchors: every hybrid neighbour model solves the same 3×3 system
// as the coupled integrator.
TEST(HybridImplicit, OneFreeQuantaEqualsCoupled) {
  World w;
  const Index c = w.add_quanta(Vec3(0.01, -0.02, 0.015), Vec3(0.3, -0.1, 0.2), 0.5);
  const Vec3 corners[] = {{1, 0, 0}, {-1, 0.2, 0}, {0, 1, 0.3}, {0.1, -1, -0.5}, {0, 0, 1}};
  std::vector<Index> anchors;
  for (const Vec3& p : corners) anchors.push_back(w.add_quanta(p, Vec3::Zero(), 1.0));
  for (Index a : anchors) w.add_bond(c, a, {.law = Law::linear, .stiffness = 80, .damping = 0.7, .rest_length = 0.9});
  w.add_bond(c, anchors[0], {.law = Law::inverse, .stiffness = 2, .damping = 0.1, .rest_length = 0.95, .shape = {0.1}});
  w.prescribe(anchors, Motion{});
  w.model.gravity = Vec3(0, 0, -9.81);
  const double h = 0.05;
  const Projection ref = test::project_once(w, coupled(CoupledSolver::ldlt), h);
  for (NeighbourModel nm : {NeighbourModel::frozen, NeighbourModel::sweep, NeighbourModel::jacobi}) {
    const Projection p = test::project_once(w, hybrid(nm), h);
    EXPECT_LE(test::max_norm_diff(p.dv, ref.dv), 1e-13 * test::max_norm(ref.dv)) << to_string(nm);
    EXPECT_LE(test::max_norm_diff(p.dx, ref.dx), 1e-13 * test::max_norm(ref.dx)) << to_string(nm);
  }
}

// A perturbed, damped, anchored 3D lattice under gravity at a stiff step (h ω ≈ 3).
World stressed_lattice() {
  World w = test::lattice(4, 3, 3, 1000, 1e-3, 0.01, true, Vec3(0, 0, -9.81));
  test::perturb(w, 5e-4, 0.05);
  return w;
}
constexpr double kStiffStep = 3e-3;

TEST(CoupledImplicit, DenseLdltAndCgAgree) {
  const World w = stressed_lattice();
  const Projection dense = test::project_once(w, coupled(CoupledSolver::dense), kStiffStep);
  const Projection ldlt = test::project_once(w, coupled(CoupledSolver::ldlt), kStiffStep);
  const Projection cg = test::project_once(w, coupled(CoupledSolver::cg, 1e-14), kStiffStep);
  const double scale = test::max_norm(dense.dv);
  EXPECT_LE(test::max_norm_diff(ldlt.dv, dense.dv), 1e-11 * scale);
  EXPECT_LE(test::max_norm_diff(cg.dv, dense.dv), 1e-11 * scale);
}

// The direct solvers keep their symbolic analysis while the matrix's pattern stays (Newton
// iterations, steps without a broken bond) and redo it when a bond breaks: each solve gives the
// bits of a solver that analyses afresh, LDLᵀ on the linearised system and LU on a non-symmetric
// one (as the Newton integrators' exact Jacobian), over two states of one pattern and one state of
// another.
TEST(DirectSolver, KeepsItsAnalysisOnlyWhileThePatternStays) {
  World w = test::lattice(4, 4, 3, 1000, 1e-3, 0.02, true, Vec3(0, 0, -9.81));
  test::perturb(w, 1e-3, 0.1);
  const std::size_t n = w.num_quanta();
  const std::vector<Vec3> f_ext(n, Vec3::Zero());
  DirectSolver kept;
  std::vector<int> analysed;  // the pattern of each solve: whether `kept` analysed it anew
  for (int round = 0; round < 3; ++round) {
    if (round == 1) test::perturb(w, 1e-3, 0.1, 11);  // other values, the same pattern
    if (round == 2) {                                  // one bond fewer: another pattern
      w.state.break_bond(static_cast<Index>(w.num_bonds() / 2));
    }
    Adjacency adj;
    build_adjacency(w.model, w.state, adj);
    ImplicitSystem sys;
    Projection kin;
    begin_implicit_step(w.model, w.state, adj, f_ext, {.h = 1e-3}, false, 1, kin, sys);
    std::vector<Vec3> y, y_fresh;
    const std::size_t inner = kept.ldlt_pattern.inner.size();
    kept.solve(CoupledSolver::ldlt, w.model, w.state, sys, y);
    DirectSolver().solve(CoupledSolver::ldlt, w.model, w.state, sys, y_fresh);
    ASSERT_EQ(y.size(), n);
    EXPECT_EQ(std::memcmp(y.data(), y_fresh.data(), n * sizeof(Vec3)), 0) << "LDLT, round " << round;
    analysed.push_back(kept.ldlt_pattern.inner.size() != inner);
    // A non-symmetric matrix of the same pattern: each bond's block plus a skew part.
    sys.exact.resize(w.num_bonds());
    for (std::size_t b = 0; b < w.num_bonds(); ++b) {
      Mat3 skew = Mat3::Zero();
      skew(0, 1) = 0.3 * sys.bonds.Ba[b];
      skew(1, 0) = -skew(0, 1);
      sys.exact[b] = block_matrix(sys.bonds.u(b), sys.bonds.Ba[b], sys.bonds.Bb[b]) + skew;
    }
    ASSERT_TRUE(kept.solve_lu(w.model, w.state, sys, y));
    ASSERT_TRUE(DirectSolver().solve_lu(w.model, w.state, sys, y_fresh));
    EXPECT_EQ(std::memcmp(y.data(), y_fresh.data(), n * sizeof(Vec3)), 0) << "LU, round " << round;
  }
  EXPECT_EQ(analysed, (std::vector<int>{1, 0, 1}));
}

// A pattern matches a matrix of the same pattern whatever its values, and only that.
TEST(DirectSolver, PatternMatchesOnlyTheSamePattern) {
  Eigen::SparseMatrix<double> a(3, 3), b(3, 3), c(3, 3);
  a.insert(0, 0) = 1;
  a.insert(2, 1) = 2;
  b.insert(0, 0) = 5;
  b.insert(2, 1) = -1;
  c.insert(0, 0) = 1;
  c.insert(1, 1) = 2;
  for (auto* m : {&a, &b, &c}) m->makeCompressed();
  SparsityPattern p;
  EXPECT_FALSE(p.matches(a));
  EXPECT_TRUE(p.matches(a));
  EXPECT_TRUE(p.matches(b));
  EXPECT_FALSE(p.matches(c));
  EXPECT_TRUE(p.matches(c));
  EXPECT_FALSE(p.matches(Eigen::SparseMatrix<double>(2, 2)));
}

// The plain reference of the implicit step: A = M + h C + h² K and b = h (f_ext + f) − h K Δx₀ −
// h C Δv_k assembled densely from the textbook 3×3 blocks of laws.hpp (stiffness_block,
// damping_block, bond_force_on_i); Δx₀ = h v for free quanta, the prescribed displacement for
// kinematic ones, and Δv_k their prescribed velocity change (0 for free ones). Returns Δv of the
// coupled step (unless !coupled: then empty, and no dense matrix is made) and of the paper's frozen
// step (Δv_k for kinematic quanta).
struct ReferenceStep {
  std::vector<Vec3> coupled, frozen;
};
ReferenceStep plain_implicit_step(const World& w, double h, bool coupled = true) {
  const Model& m = w.model;
  const State& s = w.state;
  const auto n = static_cast<Eigen::Index>(w.num_quanta());
  const Eigen::Index dense = coupled ? 3 * n : 0;
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(dense, dense), C = K;
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * n), dx0 = f, dvk = f;
  Projection kin;
  kin.resize(w.num_quanta());
  project_kinematic(m, s, {.h = h, .t = s.time, .step = s.step}, kin);
  for (Eigen::Index i = 0; i < n; ++i) {
    f.segment<3>(3 * i) = m.mass[i] * m.gravity;
    const bool free = !m.is_kinematic(static_cast<Index>(i));
    dx0.segment<3>(3 * i) = free ? Vec3(h * s.v[i]) : kin.dx[i];
    if (!free) dvk.segment<3>(3 * i) = kin.dv[i];
  }
  std::vector<Mat3> Ksum(n, Mat3::Zero()), Bsum(n, Mat3::Zero());
  for (std::size_t b = 0; b < w.num_bonds(); ++b) {
    if (!s.bonds.alive[b]) continue;
    const Index i = s.bonds.i[b], j = s.bonds.j[b];
    const Vec3 d = s.x[j] - s.x[i];
    const double r = d.norm();
    const LawValue lv = s.bonds.law_at(m.shapes, b, r, s.bonds.rest[b]);
    const Mat3 Kb = stiffness_block(lv.T, lv.dT, r, d / r, /*clamp_for_solver=*/true);
    const Mat3 Cb = damping_block(s.bonds.damping_model[b], s.bonds.damping[b], d / r);
    const Vec3 fb = s.bonds.force_on_i(m.shapes, b, d, s.v[j] - s.v[i], s.bonds.rest[b]);
    f.segment<3>(3 * i) += fb;
    f.segment<3>(3 * j) -= fb;
    if (coupled)
      for (const auto& [p, q, sign] : {std::tuple{i, i, 1.0}, {j, j, 1.0}, {i, j, -1.0}, {j, i, -1.0}}) {
        K.block<3, 3>(3 * p, 3 * q) += sign * Kb;
        C.block<3, 3>(3 * p, 3 * q) += sign * Cb;
      }
    for (Index e : {i, j}) {
      Ksum[e] += Kb;
      Bsum[e] += h * Cb + h * h * Kb;
    }
  }
  ReferenceStep ref{kin.dv, kin.dv};  // kinematic quanta: their prescribed Δv
  for (Eigen::Index i = 0; i < n; ++i) {
    if (m.is_kinematic(static_cast<Index>(i))) continue;
    // Eq. 12: A_ii Δv_i = h (f_ext + Σ ±f_b) − h² (Σ K_b) v_i.
    const Vec3 rhs = h * Vec3(f.segment<3>(3 * i)) - h * h * (Ksum[i] * s.v[i]);
    ref.frozen[i] = (m.mass[i] * Mat3::Identity() + Bsum[i]).partialPivLu().solve(rhs);
  }
  if (!coupled) {
    ref.coupled.clear();
    return ref;
  }
  const Eigen::VectorXd b = h * f - h * K * dx0 - h * C * dvk;
  std::vector<Eigen::Index> free;
  for (Eigen::Index i = 0; i < n; ++i)
    if (!m.is_kinematic(static_cast<Index>(i))) free.push_back(i);
  const auto nf = static_cast<Eigen::Index>(free.size());
  Eigen::MatrixXd A(3 * nf, 3 * nf);
  Eigen::VectorXd bf(3 * nf);
  for (Eigen::Index p = 0; p < nf; ++p) {
    bf.segment<3>(3 * p) = b.segment<3>(3 * free[p]);
    for (Eigen::Index q = 0; q < nf; ++q)
      A.block<3, 3>(3 * p, 3 * q) = h * C.block<3, 3>(3 * free[p], 3 * free[q]) +
                                    h * h * K.block<3, 3>(3 * free[p], 3 * free[q]) +
                                    (p == q ? Mat3(m.mass[free[p]] * Mat3::Identity()) : Mat3::Zero());
  }
  const Eigen::VectorXd y = A.partialPivLu().solve(bf);
  for (Eigen::Index p = 0; p < nf; ++p) ref.coupled[free[p]] = y.segment<3>(3 * p);
  return ref;
}

// The integrators' step (bond blocks kept as a u uᵀ + b I, built bond-centric, gathered per
// quanta) against the plain dense assembly, on a random lattice with everything that changes a
// block: both laws (the inverse law softening and compressed bonds: clamped), both damping
// models, plastic rest lengths, broken bonds, a turning anchored face and gravity. The inverse law and
// mixed damping models are given to bonds of the second half only, so that the frozen step's runs
// of 64 bonds (hybrid_frozen_kernel.cpp) include uniform ones (its vectorised law) and mixed ones; the
// lattice is stepped with and
// without broken bonds (its runs then are lists, or the consecutive bonds), and in the builder's
// bond order and in the offset-grouped order of scene loading (ordering.hpp), where most runs
// are affine (contiguous loads, vector row updates).
TEST(ImplicitStep, MatchesThePlainAssemblyOnARandomLattice) {
  for (bool grouped : {false, true}) {
    for (bool broken : {true, false}) {
      const std::string what = std::string(grouped ? "grouped" : "builder's order") + (broken ? ", broken" : "");
      World w = test::lattice(10, 4, 3, 1000, 1e-3, 0.02, true, Vec3(0, 0, -9.81));
      if (grouped) renumber(w, locality_order(w));
      ASSERT_GT(w.num_bonds(), 4 * kBondRun);
      // The frozen step's fused path for runs of one law and damping model, and its general one.
      test::mix_bonds(w);
      // The anchored face turns about the x axis: its prescribed Δx and Δv enter the coupled step.
      Motion& face = w.model.motions.at(0);
      face.type = MotionType::rotate;
      face.axis = Vec3::UnitX();
      face.center = Vec3(0, 0.015, 0.01);
      face.rate = 30;
      Rng rng{11};
      for (std::size_t b = 0; b < w.num_bonds(); ++b) {
        w.state.bonds.rest[b] *= 1 + 0.05 * (2 * rng.uniform() - 1);
        if (broken && b % 17 == 5) w.state.bonds.alive[b] = 0;
      }
      Adjacency adj;
      build_adjacency(w.model, w.state, adj);
      BondPartition part;
      part.update(w.model, w.state.bonds, adj, 1);
      const auto affine = std::count_if(part.runs.begin(), part.runs.end(), [](const BondRun& r) { return r.affine; });
      if (grouped)
        EXPECT_GE(affine, 4) << what;
      else
        EXPECT_EQ(affine, 0) << what;
      test::perturb(w, 2e-3, 0.2);  // strains of tens of percent: the inverse law's softening branch
      const double h = 3e-3;
      const ReferenceStep ref = plain_implicit_step(w, h);
      const double scale = test::max_norm(ref.coupled);
      ASSERT_GT(scale, 0);
      for (CoupledSolver solver : {CoupledSolver::dense, CoupledSolver::ldlt}) {
        const Projection p = test::project_once(w, coupled(solver), h);
        EXPECT_LE(test::max_norm_diff(p.dv, ref.coupled), 1e-11 * scale) << to_string(solver) << ", " << what;
      }
      const Projection frozen = test::project_once(w, hybrid(NeighbourModel::frozen), h);
      EXPECT_LE(test::max_norm_diff(frozen.dv, ref.frozen), 1e-12 * test::max_norm(ref.frozen)) << what;
    }
  }
}

// The frozen step starts each part's rows just before its bond pass reaches them and solves them
// once the pass is past them (hybrid_frozen_kernel.cpp). On three lattices, the first two numbered apart by
// more than one of the pass's pieces, with unbonded quanta numbered between them (rows that no
// run reaches), their runs affine and uniform, the third's of both laws and damping models and
// broken bonds (the per-bond path, whose last row's sum is added only when the next run begins),
// it matches the plain step, and gives the same bits on 1, 2 and 3 threads (two parts from
// 2) and in pieces of any size; a world without bonds falls freely.
TEST(ImplicitStep, FrozenRowsStartedAndSolvedInTheBondPassMatchThePlainStep) {
  World w = test::lattice(24, 16, 6, 1000, 1e-3, 0.02, true, Vec3(0, 0, -9.81));
  for (int k = 0; k < 700; ++k) w.add_quanta(Vec3(0.01 * (k % 24), 0.01 * (k / 24), 0.2), Vec3(0.1, 0, 0), 1e-3);
  for (Index body : {1, 2}) {
    CubicLattice upper;
    upper.size = {24, 16, 6};
    upper.origin = Vec3(0, 0, 0.5 * body);
    upper.bond = {.law = Law::linear, .stiffness = 1000, .damping = 0.02};
    add_cubic_lattice(w, upper, body);
  }
  ASSERT_GE(w.num_quanta(), 4096u);  // kParallelMin: two parts from 2 threads
  renumber(w, locality_order(w));
  Rng rng{5};
  for (std::size_t b = 0; b < w.num_bonds(); ++b) {
    w.state.bonds.rest[b] *= 1 + 0.05 * (2 * rng.uniform() - 1);
    if (w.model.body[w.state.bonds.i[b]] != 2) continue;  // the lower lattices' runs affine and uniform
    if (b % 3 == 0) {
      w.state.bonds.law[b] = Law::inverse;
      const double eps = InverseLaw::eps(w.state.bonds.law_args(w.model.shapes, b));
      w.state.bonds.strength[b] *= eps * eps;
    }
    if (b % 4 == 0) w.state.bonds.damping_model[b] = DampingModel::isotropic;
    if (b % 23 == 7) w.state.bonds.alive[b] = 0;
  }
  test::perturb(w, 2e-3, 0.2);
  const double h = 3e-3;
  const ReferenceStep ref = plain_implicit_step(w, h, /*coupled=*/false);
  Adjacency adj;
  build_adjacency(w.model, w.state, adj);
  std::vector<Vec3> f_ext(w.num_quanta());
  for (std::size_t i = 0; i < w.num_quanta(); ++i) f_ext[i] = w.model.mass[i] * w.model.gravity;
  const StepContext ctx{.h = h, .t = w.state.time, .step = w.state.step};
  std::vector<Vec3> first;
  for (Index wake : {Index{512}, Index{8}})  // the step's pieces, and many more of them
    for (int threads : {1, 2, 3}) {
      FrozenStep step;
      step.wake = wake;
      Projection p;
      step.project(w.model, w.state, adj, f_ext, ctx, threads, p, nullptr);
      const std::string what = std::to_string(threads) + " threads, pieces of " + std::to_string(wake);
      // Advanced in place, the step writes x + dx and v + dv of its projection, the same bits.
      FrozenStep fused;
      fused.wake = wake;
      Projection empty;
      Advanced to, applied;
      fused.project(w.model, w.state, adj, f_ext, ctx, threads, empty, &to);
      PrescribedAt prescribed;
      apply_checked(w.model, w.state, p, ctx.t + ctx.h, threads, prescribed, applied);
      EXPECT_TRUE(to.ok && applied.ok) << what;
      EXPECT_TRUE(empty.dx.empty() && empty.dv.empty()) << what;
      EXPECT_EQ(std::memcmp(to.x.data(), applied.x.data(), sizeof(Vec3) * applied.x.size()), 0) << what;
      EXPECT_EQ(std::memcmp(to.v.data(), applied.v.data(), sizeof(Vec3) * applied.v.size()), 0) << what;
      EXPECT_LE(test::max_norm_diff(p.dv, ref.frozen), 1e-12 * test::max_norm(ref.frozen)) << what;
      if (first.empty())
        first = p.dv;
      else
        EXPECT_EQ(std::memcmp(p.dv.data(), first.data(), sizeof(Vec3) * first.size()), 0) << what;
    }
  // No bonds: no part has a run, and the rows are started and solved after the bond pass.
  World gas;
  gas.model.gravity = Vec3(0, 0, -9.81);
  for (int k = 0; k < 10; ++k) gas.add_quanta(Vec3(0.1 * k, 0, 0), Vec3(k, 0, 0), 1e-3);
  const Projection p = test::project_once(gas, hybrid(NeighbourModel::frozen), h);
  for (const Vec3& dv : p.dv) EXPECT_LE((dv - h * gas.model.gravity).norm(), 1e-12);
}

// A quanta of zero mass is prescribed without a motion: it stays where it is, whatever bonds pull
// on it (the frozen step solves every row in one vector loop and must not apply that one's).
TEST(Integrators, AZeroMassQuantaStaysPut) {
  World w = test::lattice(4, 3, 3, 1000, 1e-3, 0.02, false, Vec3(0, 0, -9.81));
  const Index fixed = w.add_quanta(Vec3(-0.01, 0, 0), Vec3::Zero(), 0.0);
  w.add_bond(fixed, 0, {.law = Law::linear, .stiffness = 1000, .damping = 0.02});
  const Index loose = w.add_quanta(Vec3(0.5, 0.5, 0.5), Vec3(1, 0, 0), 0.0);  // no bonds: no row to solve
  test::perturb(w, 1e-3, 0.1);
  for (const IntegratorConfig& cfg : {hybrid(NeighbourModel::frozen), hybrid(NeighbourModel::sweep),
                                      test::config(IntegratorType::velocity_verlet), default_integrator()}) {
    const Projection p = test::project_once(w, cfg, 1e-3);
    for (Index q : {fixed, loose}) {
      EXPECT_EQ(p.dx[q], Vec3::Zero()) << to_string(cfg.type) << ", quanta " << q;
      EXPECT_EQ(p.dv[q], Vec3::Zero()) << to_string(cfg.type) << ", quanta " << q;
    }
    EXPECT_TRUE(p.dv[0].allFinite() && p.dv[0] != Vec3::Zero()) << to_string(cfg.type);
  }
}

// The steps that write the prescribed quanta's rows along with their range's (PrescribedAt) give
// them project_kinematic's rows on any thread count, however the motions list them: out of index
// order, and a quanta listed by two motions (the later one's, as place_kinematic leaves it).
TEST(Integrators, PrescribedRowsAreProjectKinematicsOnAnyThreadCount) {
  World w = test::lattice(18, 16, 15, 1000, 1e-3, 0.02, false, Vec3(0, 0, -9.81));  // 4 320: several threads
  test::perturb(w, 1e-4, 0.05);
  std::vector<Index> pulled, turned;
  for (Index q = 0; q < w.num_quanta(); q += 7) (q % 2 ? pulled : turned).push_back(q);
  std::reverse(pulled.begin(), pulled.end());
  turned.insert(turned.end(), pulled.begin(), pulled.begin() + 40);  // listed by both
  Motion pull, turn;
  pull.type = MotionType::translate;
  pull.velocity = Vec3(0.1, -0.2, 0.3);
  turn.type = MotionType::rotate;
  turn.axis = Vec3(1, 1, 0);
  turn.center = Vec3(0.05, 0.05, 0.05);
  turn.rate = 3;
  w.prescribe(pulled, pull);
  w.prescribe(turned, turn);
  const double h = 1e-4;
  const StepContext ctx{h, w.state.time, w.state.step};
  Projection kin;
  kin.resize(w.num_quanta());
  project_kinematic(w.model, w.state, ctx, kin);
  for (IntegratorConfig cfg : {hybrid(NeighbourModel::frozen), hybrid(NeighbourModel::sweep),
                               test::config(IntegratorType::velocity_verlet), default_integrator()})
    for (int threads : {1, 2, 3}) {
      cfg.threads = threads;
      const Projection p = test::project_once(w, cfg, h);
      for (const std::vector<Index>* list : {&pulled, &turned})
        for (Index q : *list) {
          ASSERT_EQ(p.dx[q], kin.dx[q]) << to_string(cfg.type) << ", " << threads << " threads, quanta " << q;
          ASSERT_EQ(p.dv[q], kin.dv[q]) << to_string(cfg.type) << ", " << threads << " threads, quanta " << q;
        }
    }
}

TEST(HybridImplicit, SweepConvergesToCoupledAsIterationsGrow) {
  const World w = stressed_lattice();
  const Projection ref = test::project_once(w, coupled(CoupledSolver::ldlt), kStiffStep);
  const double scale = test::max_norm(ref.dv);
  auto diff = [&](int sweeps, double rho, double tol) {
    IntegratorConfig cfg = hybrid(NeighbourModel::sweep, sweeps);
    cfg.tolerance = tol;
    cfg.chebyshev_rho = rho;
    return test::max_norm_diff(test::project_once(w, cfg, kStiffStep).dv, ref.dv) / scale;
  };
  double previous = INFINITY;
  for (int it : {1, 2, 4, 8, 16, 32, 64, 128}) {
    const double d = diff(it, 0.0, 0.0);  // tolerance 0: exactly `it` sweeps
    EXPECT_LT(d, previous) << it << " sweeps";
    previous = d;
  }
  // Chebyshev acceleration (spectral-radius estimate 0.8) is not monotone in its first sweeps
  // but gets closer in the same number of sweeps.
  EXPECT_LT(diff(64, 0.8, 0.0), 0.1 * diff(64, 0.0, 0.0));
  for (double rho : {0.0, 0.8}) EXPECT_LT(diff(5000, rho, 1e-13), 1e-10) << "rho " << rho;
}

TEST(HybridImplicit, JacobiConvergesToCoupled) {
  // Block Jacobi converges here (the step is stiff but the matrix is diagonally dominant enough).
  const World w = stressed_lattice();
  const Projection ref = test::project_once(w, coupled(CoupledSolver::ldlt), 1e-4);
  IntegratorConfig cfg = hybrid(NeighbourModel::jacobi, 5000);
  cfg.tolerance = 1e-13;
  EXPECT_LT(test::max_norm_diff(test::project_once(w, cfg, 1e-4).dv, ref.dv) / test::max_norm(ref.dv), 1e-10);
}

TEST(CoupledImplicit, CgStopsAtItsTolerance) {
  const World w = stressed_lattice();
  Simulation sim(w, coupled(CoupledSolver::cg, 1e-6), kStiffStep);
  sim.begin_step();
  EXPECT_LE(sim.integrator().stats().residual, 1e-6);
  EXPECT_GT(sim.integrator().stats().iterations, 0);
  Simulation tight(w, coupled(CoupledSolver::cg, 1e-12), kStiffStep);
  tight.begin_step();
  EXPECT_GT(tight.integrator().stats().iterations, sim.integrator().stats().iterations);
}

// CG stops at ‖b − AΔv‖ ≤ τ max(‖b‖, h‖f_ext‖): a body settled under gravity, whose forces balance
// so that b → 0, is solved in a few iterations a step, and stays within what the criterion allows
// of the direct solve's run: a step's Δv within κ τ ‖Δv*‖ + τ h ‖f_ext‖/m of the exact one (A's
// eigenvalues at least m, κ ≤ 1 + 2 z (h c + h² k)/m by Gershgorin), summed over the S steps
// (backward Euler's step does not amplify an error).
TEST(CoupledImplicit, CgAtRestStopsAgainstTheExternalImpulse) {
  constexpr double kTau = 1e-6, kH = 1.0 / 60, kM = 1e-3, kK = 50, kC = 0.5, kG = 9.81;
  constexpr int kSteps = 240, kZ = 18;
  const World w = test::lattice(8, 4, 4, kK, kM, kC, true, Vec3(0, 0, -kG));
  IntegratorConfig cg = coupled(CoupledSolver::cg, kTau);
  cg.preconditioner = Preconditioner::block_jacobi;
  cg.restore_momentum = false;  // the comparison is with the linear systems' own solutions
  IntegratorConfig direct = coupled(CoupledSolver::ldlt);
  direct.restore_momentum = false;
  Simulation a(w, cg, kH), b(w, direct, kH);
  double vmax = 0;
  int resting_iterations = 0;
  for (int s = 0; s < kSteps; ++s) {
    a.step();
    b.step();
    EXPECT_LE(a.integrator().stats().residual, kTau);
    if (s >= kSteps - 60) resting_iterations = std::max(resting_iterations, a.integrator().stats().iterations);
    double v2 = 0;
    for (const Vec3& v : b.world().state.v) v2 += v.squaredNorm();
    vmax = std::max(vmax, std::sqrt(v2));
  }
  double kinetic = 0;
  for (const Vec3& v : b.world().state.v) kinetic += 0.5 * kM * v.squaredNorm();
  ASSERT_LT(kinetic, 1e-12);  // settled: b is the small difference of balancing forces
  EXPECT_LE(resting_iterations, 3);
  const double kappa = 1 + 2 * kZ * (kH * kC + kH * kH * kK) / kM;
  const double free = static_cast<double>(w.num_quanta() - 32);  // the x = 0 face is anchored
  const double bound = kSteps * (2 * kappa * kTau * vmax + kTau * kH * std::sqrt(free) * kG);
  double dv2 = 0;
  for (std::size_t i = 0; i < w.num_quanta(); ++i) dv2 += (a.world().state.v[i] - b.world().state.v[i]).squaredNorm();
  EXPECT_LE(std::sqrt(dv2), bound);
}

// WarmStart::automatic, the default: extrapolated from the last two steps' Δv for CG (the coupled
// integrator's default solver), zero for the sweeps (which blow up from it) and every other solver.
TEST(WarmStart, AutomaticIsExtrapolatedForCgAndZeroOtherwise) {
  EXPECT_EQ(default_integrator().warm_start, WarmStart::automatic);
  EXPECT_EQ(make_integrator(default_integrator())->config().warm_start, WarmStart::extrapolated);
  for (const IntegratorConfig& c : {coupled(CoupledSolver::ldlt), hybrid(NeighbourModel::sweep),
                                    hybrid(NeighbourModel::jacobi), test::config(IntegratorType::bdf2),
                                    test::config(IntegratorType::energy_momentum)})
    EXPECT_EQ(make_integrator(c)->config().warm_start, WarmStart::zero) << to_string(c.type);
  for (WarmStart w : {WarmStart::automatic, WarmStart::extrapolated, WarmStart::previous})
    EXPECT_EQ(parse_warm_start(to_string(w)), w);
  // A Newton integrator's substeps have no earlier steps of their length to extrapolate from.
  IntegratorConfig newton = test::config(IntegratorType::implicit_midpoint);
  newton.warm_start = WarmStart::extrapolated;
  EXPECT_THROW(make_integrator(newton), std::invalid_argument);
}

// The extrapolated guess: 2 Δv₋₁ − Δv₋₂ after two steps of this step's length, the previous Δv
// after steps of another length or a `previous` carry-over, nothing from no carry-over or bdf2's;
// kinematic rows 0.
TEST(WarmStart, ExtrapolatesOnlyBetweenStepsOfTheSameLength) {
  World w = test::lattice(3, 2, 2, 1000, 1e-3, 0.01, true);
  const Model& m = w.model;
  const std::size_t n = w.num_quanta();
  std::vector<Vec3> dv1(n), dv2(n), f(n, Vec3::Zero()), y;
  for (std::size_t i = 0; i < n; ++i) {
    dv1[i] = Vec3(0.1 * i, 1, -2);
    dv2[i] = Vec3(0.3 * i, -1, 5);
  }
  const double h = 1e-3;
  Projection p1, p2;
  keep_guess(WarmStart::extrapolated, dv1, h, {}, 1, p1);
  keep_guess(WarmStart::extrapolated, dv2, h, p1.carry, 1, p2);
  const Carry &carry1 = p1.carry, &carry2 = p2.carry;
  ASSERT_TRUE(std::holds_alternative<SolverGuessPair>(carry2));
  EXPECT_EQ(std::get<SolverGuessPair>(carry2).h_before, h);
  EXPECT_EQ(std::get<SolverGuessPair>(carry1).h_before, 0.0);
  auto expect_free_rows = [&](const auto& want) {
    for (std::size_t i = 0; i < n; ++i)
      EXPECT_EQ(y[i], m.is_kinematic(static_cast<Index>(i)) ? Vec3::Zero() : Vec3(want(i))) << i;
  };
  ASSERT_TRUE(initial_guess(WarmStart::extrapolated, m, f, h, carry2, 1, y));
  expect_free_rows([&](std::size_t i) { return 2 * dv2[i] - dv1[i]; });
  // After one step only (no Δv₋₂), at another length, or from `previous`'s carry-over: Δv₋₁.
  ASSERT_TRUE(initial_guess(WarmStart::extrapolated, m, f, h, carry1, 1, y));
  expect_free_rows([&](std::size_t i) { return dv1[i]; });
  ASSERT_TRUE(initial_guess(WarmStart::extrapolated, m, f, 2 * h, carry2, 1, y));
  expect_free_rows([&](std::size_t i) { return dv2[i]; });
  ASSERT_TRUE(initial_guess(WarmStart::extrapolated, m, f, h, SolverGuess{LineVector<Vec3>(dv2.begin(), dv2.end())},
                            1, y));
  expect_free_rows([&](std::size_t i) { return dv2[i]; });
  ASSERT_TRUE(initial_guess(WarmStart::previous, m, f, h, carry2, 1, y));
  expect_free_rows([&](std::size_t i) { return dv2[i]; });
  // bdf2's carry-over, x and v of the state before: not a Δv.
  const Bdf2History bdf2{std::vector<Vec3>(n, Vec3::Ones()), std::vector<Vec3>(n, Vec3::Ones()), 0.5, h, 7};
  EXPECT_FALSE(initial_guess(WarmStart::extrapolated, m, f, h, bdf2, 1, y));
  EXPECT_FALSE(initial_guess(WarmStart::extrapolated, m, f, h, {}, 1, y));
}

// On the canonical lattice sagging under gravity (a smooth motion), CG from the extrapolated guess
// reaches the same tolerance in fewer iterations than from the previous step's Δv.
TEST(CoupledImplicit, ExtrapolatedGuessTakesFewerIterationsOnASmoothMotion) {
  auto iterations = [](WarmStart start) {
    Scene scene = canonical_lattice(10);
    IntegratorConfig c = default_integrator();
    c.warm_start = start;
    Simulation sim(std::move(scene.world), c, scene.timestep);
    int total = 0;
    for (int k = 0; k < 20; ++k) {
      EXPECT_EQ(sim.step().status, StepReport::Status::ok);
      EXPECT_LE(sim.integrator().stats().residual, c.tolerance);
      if (k >= 2) total += sim.integrator().stats().iterations;
    }
    return total;
  };
  const int previous = iterations(WarmStart::previous), extrapolated = iterations(WarmStart::extrapolated);
  EXPECT_LT(extrapolated, previous) << "iterations over 18 steps from each start";
}

// CG scales its guess by yᵀb / yᵀA y before iterating: a guess along the solution (twice it, or
// minus three times it) is scaled onto it, and CG stops at once.
TEST(CoupledImplicit, CgScalesItsGuessOntoTheSolution) {
  const World w = stressed_lattice();
  const Projection exact = test::project_once(w, coupled(CoupledSolver::cg, 1e-14), kStiffStep);
  for (double f : {2.0, -3.0}) {
    World guessed = w;
    SolverGuess& guess = guessed.state.carry.emplace<SolverGuess>();
    for (std::size_t i = 0; i < w.num_quanta(); ++i) guess.dv.push_back(f * exact.dv[i]);
    Simulation sim(guessed, coupled(CoupledSolver::cg, 1e-9), kStiffStep);
    sim.begin_step();
    EXPECT_EQ(sim.integrator().stats().iterations, 0) << f;
    EXPECT_LE(test::max_norm_diff(sim.projection().dv, exact.dv), 1e-12 * test::max_norm(exact.dv)) << f;
  }
}

TEST(Integrators, NamesRoundTripAndBadOptionsAreRejected) {
  for (auto t : {IntegratorType::explicit_euler, IntegratorType::symplectic_euler, IntegratorType::velocity_verlet,
                 IntegratorType::rk4, IntegratorType::hybrid_implicit, IntegratorType::coupled_implicit})
    EXPECT_EQ(parse_integrator_type(to_string(t)), t);
  EXPECT_THROW(parse_integrator_type("implicit"), std::invalid_argument);
  IntegratorConfig bad = hybrid(NeighbourModel::sweep, 0);
  EXPECT_THROW(make_integrator(bad), std::invalid_argument);
  bad = hybrid(NeighbourModel::sweep);
  bad.chebyshev_rho = 1.0;
  EXPECT_THROW(make_integrator(bad), std::invalid_argument);
}

// A damped lattice under gravity whose x = 0 face is anchored and whose x = max face is pulled
// along y (a prescribed motion), for the Verlet tests.
World pulled_lattice() {
  World w = test::lattice(6, 4, 3, 1000, 1e-3, 0.01, true, Vec3(0, 0, -9.81));
  test::perturb(w, 5e-4, 0.05);
  std::vector<Index> face;
  for (std::size_t i = 0; i < w.num_quanta(); ++i)
    if (w.state.x[i].x() == 0.05) face.push_back(static_cast<Index>(i));
  Motion pull;
  pull.type = MotionType::translate;
  pull.velocity = Vec3(0, 0.2, 0);
  w.prescribe(face, pull);
  return w;
}

// Bond forces summed per quanta the plain way: bond_forces' per-bond force, both ends, in bond order.
std::vector<Vec3> plain_bond_sums(const World& w, const std::vector<Vec3>& x, const std::vector<Vec3>& v) {
  std::vector<Vec3> fb, f(w.num_quanta(), Vec3::Zero());
  bond_forces(w.model, w.state, x, v, 1, fb);
  for (std::size_t b = 0; b < w.num_bonds(); ++b) {
    f[w.state.bonds.i[b]] += fb[b];
    f[w.state.bonds.j[b]] -= fb[b];
  }
  return f;
}

// Groot and Warren's velocity Verlet (λ = 1) written out plainly: each step's first force is the
// previous step's second, evaluated at the predicted velocity ṽ = v + h a; the first step's at
// (x, v). `carry` = false evaluates a(x, v) every step instead (the two-pass method).
std::vector<Vec3> plain_verlet(World w, double h, int steps, bool carry) {
  const Model& m = w.model;
  State& s = w.state;
  const std::size_t n = w.num_quanta();
  std::vector<Vec3> f = plain_bond_sums(w, s.x, s.v), x1(n), vt(n), v1(n);
  auto accel = [&](const std::vector<Vec3>& fb, std::size_t i) {
    return m.inv_mass[i] * (fb[i] + m.mass[i] * m.gravity);
  };
  for (int k = 0; k < steps; ++k) {
    if (!carry) f = plain_bond_sums(w, s.x, s.v);
    const double t1 = s.time + h;
    for (std::size_t i = 0; i < n; ++i) {
      x1[i] = s.x[i] + h * s.v[i] + 0.5 * h * h * accel(f, i);
      vt[i] = s.v[i] + h * accel(f, i);
    }
    place_kinematic(m, t1, x1.data(), vt.data());
    const std::vector<Vec3> f1 = plain_bond_sums(w, x1, vt);
    for (std::size_t i = 0; i < n; ++i) v1[i] = s.v[i] + 0.5 * h * (accel(f, i) + accel(f1, i));
    place_kinematic(m, t1, x1.data(), v1.data());
    s.x = x1, s.v = v1, s.time = t1, f = f1;
  }
  return s.x;
}

// qbond's Verlet takes one force pass a step by carrying the last one over: it must be Groot and
// Warren's method to round-off (the vector kernels sum in another order), on 1 and 2 threads, and
// measurably not the two-pass method (a(x, v) evaluated afresh every step).
TEST(VelocityVerlet, IsGrootWarrenWithTheLastStepsForces) {
  const double h = 1e-4;
  const int steps = 40;
  const World w = pulled_lattice();
  const std::vector<Vec3> ref = plain_verlet(w, h, steps, true), two_pass = plain_verlet(w, h, steps, false);
  double moved = 0;
  for (std::size_t i = 0; i < ref.size(); ++i) moved = std::max(moved, (ref[i] - w.state.x[i]).norm());
  const double tol = 1e-12 * moved;
  EXPECT_GT(test::max_norm_diff(ref, two_pass), 1e3 * tol);  // the tolerance tells the two apart
  for (int threads : {1, 2}) {
    IntegratorConfig cfg = test::config(IntegratorType::velocity_verlet);
    cfg.threads = threads;
    Simulation sim(w, cfg, h);
    for (int k = 0; k < steps; ++k) sim.step();
    EXPECT_LE(test::max_norm_diff(sim.world().state.x, ref), tol) << threads << " threads";
    EXPECT_TRUE(std::holds_alternative<VerletForces>(sim.world().state.carry));
  }
}

// The carried forces are used only for the exact state they were left for: any change of a
// position, a velocity or the topology gives the step a fresh evaluation, the same bits as with
// no carry-over at all; a checkpoint carries them, so a resumed run continues bit for bit.
TEST(VelocityVerlet, CarriesItsForcesOnlyForTheStateItLeft) {
  const IntegratorConfig cfg = test::config(IntegratorType::velocity_verlet);
  const double h = 1e-4;
  Simulation a(pulled_lattice(), cfg, h);
  for (int k = 0; k < 10; ++k) a.step();
  auto fresh = [&](World w) {
    w.state.carry = std::monostate{};
    return test::project_once(w, cfg, h);
  };
  const World& now = a.world();
  EXPECT_NE(test::project_once(now, cfg, h).dv, fresh(now).dv);  // the carry-over is used
  World edited = now;
  edited.state.v[7].y() = std::nextafter(edited.state.v[7].y(), 1.0);
  EXPECT_EQ(test::project_once(edited, cfg, h).dv, fresh(edited).dv);
  edited = now;
  edited.state.x[11].z() = std::nextafter(edited.state.x[11].z(), 1.0);
  EXPECT_EQ(test::project_once(edited, cfg, h).dv, fresh(edited).dv);
  edited = now;
  edited.break_bond(5);
  EXPECT_EQ(test::project_once(edited, cfg, h).dv, fresh(edited).dv);

  World resumed = pulled_lattice();
  resumed.state = deserialize_state(serialize_state(now.state));
  Simulation b(std::move(resumed), cfg, h);
  for (int k = 0; k < 10; ++k) {
    a.step();
    b.step();
  }
  test::expect_same_bits(a.world().state, b.world().state);
}

// Plastic flow edits rest lengths within a topology: the step drops the carried forces, and keeps
// them in steps where no bond flowed.
TEST(VelocityVerlet, PlasticFlowDropsTheCarriedForces) {
  World w = test::two_quanta(1e-3, 1000, 0.01, 2e-4, 0.0, 0.01);
  Simulation sim(std::move(w), test::config(IntegratorType::velocity_verlet), 1e-5);
  sim.add_heuristic(make_heuristic(PlasticRule{.yield_strain = 0.01}));  // the 2% stretch flows at once
  sim.step();
  EXPECT_TRUE(std::holds_alternative<std::monostate>(sim.world().state.carry));
  const double rest = sim.world().state.bonds.rest[0];
  sim.step();  // shortening: back within the yield surface
  ASSERT_EQ(sim.world().state.bonds.rest[0], rest);
  EXPECT_TRUE(std::holds_alternative<VerletForces>(sim.world().state.carry));
}

// Whether v is an enumerator of IntegratorType. The switch names every enumerator: -Wswitch (an
// error in this build) refuses an enumerator left out, so a new integrator must be added here,
// and the test below then needs its row in the integrator table.
bool is_integrator_type(int v) {
  switch (static_cast<IntegratorType>(v)) {
    case IntegratorType::explicit_euler:
    case IntegratorType::symplectic_euler:
    case IntegratorType::velocity_verlet:
    case IntegratorType::rk4:
    case IntegratorType::hybrid_implicit:
    case IntegratorType::coupled_implicit:
    case IntegratorType::energy_momentum:
    case IntegratorType::implicit_midpoint:
    case IntegratorType::bdf2:
      return true;
  }
  return false;
}

TEST(IntegratorTable, HasEveryIntegratorOnceInEnumOrder) {
  const auto table = integrator_table();
  std::size_t count = 0;
  for (int v = 0; v < 256; ++v) {
    if (!is_integrator_type(v)) continue;
    ++count;
    const auto t = static_cast<IntegratorType>(v);
    ASSERT_LT(static_cast<std::size_t>(v), table.size()) << "no row for enumerator " << v;
    EXPECT_EQ(table[static_cast<std::size_t>(v)].type, t);
    EXPECT_EQ(&integrator_info(t), &table[static_cast<std::size_t>(v)]);
  }
  EXPECT_EQ(table.size(), count);
  for (const IntegratorInfo& row : table) {
    EXPECT_FALSE(row.description.empty()) << row.key;
    EXPECT_EQ(to_string(row.type), row.key);
    EXPECT_EQ(parse_integrator_type(row.key), row.type);
    // Every integrator reads the options Simulation and the thread pool apply to all.
    EXPECT_TRUE(row.reads(IntegratorOption::threads)) << row.key;
    EXPECT_TRUE(row.reads(IntegratorOption::restore_energy)) << row.key;
    // The value lists go with the options.
    EXPECT_EQ(row.reads(IntegratorOption::solver), !row.solvers.empty()) << row.key;
    EXPECT_EQ(row.reads(IntegratorOption::warm_start), !row.warm_starts.empty()) << row.key;
    // Its constructor makes it from the defaults with its own type.
    IntegratorConfig c;
    c.type = row.type;
    if (!row.solvers.empty()) c.solver = row.solvers.front();
    EXPECT_EQ(make_integrator(c)->config().type, row.type) << row.key;
  }
  EXPECT_THROW(parse_integrator_type("nonsense"), std::invalid_argument);
}

TEST(IntegratorTable, OptionsAndValuesAreListedOnceAndUsed) {
  std::uint16_t seen = 0;
  for (const IntegratorOptionInfo& o : integrator_options()) {
    const auto bit = static_cast<std::uint16_t>(o.option);
    EXPECT_EQ(seen & bit, 0) << o.key << " listed twice";
    seen = static_cast<std::uint16_t>(seen | bit);
    EXPECT_EQ(to_string(o.option), o.key);
    EXPECT_FALSE(o.description.empty()) << o.key;
    const auto table = integrator_table();
    EXPECT_TRUE(std::any_of(table.begin(), table.end(), [&](const IntegratorInfo& i) { return i.reads(o.option); }))
        << o.key << " is read by no integrator";
  }
  // Which integrator reads which option, as the options' rows say it (their read_by).
  using O = IntegratorOption;
  const std::vector<O> every = {O::threads, O::restore_energy};
  std::vector<O> solving = every;
  solving.insert(solving.end(), {O::tolerance, O::warm_start, O::restore_momentum});
  std::vector<O> newton = solving;
  newton.insert(newton.end(),
                {O::solver, O::iterations, O::max_iterations, O::chebyshev_rho, O::newton_iterations});
  auto with = [](std::vector<O> a, std::initializer_list<O> b) {
    a.insert(a.end(), b);
    return a;
  };
  const std::vector<std::pair<IntegratorType, std::vector<O>>> reads = {
      {IntegratorType::explicit_euler, every},
      {IntegratorType::symplectic_euler, every},
      {IntegratorType::velocity_verlet, every},
      {IntegratorType::rk4, every},
      {IntegratorType::hybrid_implicit, with(solving, {O::neighbours, O::iterations, O::chebyshev_rho})},
      {IntegratorType::coupled_implicit, with(solving, {O::solver, O::max_iterations, O::preconditioner})},
      {IntegratorType::energy_momentum, with(newton, {O::newton_polish})},
      {IntegratorType::implicit_midpoint, with(newton, {O::newton_polish})},
      {IntegratorType::bdf2, newton}};
  ASSERT_EQ(reads.size(), integrator_table().size());
  for (const auto& [type, options] : reads)
    for (const IntegratorOptionInfo& o : integrator_options())
      EXPECT_EQ(integrator_info(type).reads(o.option),
                std::find(options.begin(), options.end(), o.option) != options.end())
          << to_string(type) << " " << o.key;
  for (const auto& n : neighbour_models()) EXPECT_EQ(parse_neighbour_model(n.key), n.value);
  for (const auto& n : coupled_solvers()) EXPECT_EQ(parse_coupled_solver(n.key), n.value);
  for (const auto& n : warm_starts()) EXPECT_EQ(parse_warm_start(n.key), n.value);
}

// The table's value lists are what make_integrator accepts: coupled_implicit takes no sweeps, the
// Newton integrators no extrapolated start, bdf2 no previous one.
TEST(IntegratorTable, MakeIntegratorChecksTheTablesValues) {
  for (const IntegratorInfo& row : integrator_table())
    for (const auto& s : coupled_solvers()) {
      IntegratorConfig c;
      c.type = row.type;
      c.solver = s.value;
      const bool listed = std::find(row.solvers.begin(), row.solvers.end(), s.value) != row.solvers.end();
      if (!row.reads(IntegratorOption::solver) || listed) {
        EXPECT_NO_THROW(make_integrator(c)) << row.key << " " << s.key;
      } else {
        EXPECT_THROW(make_integrator(c), std::invalid_argument) << row.key << " " << s.key;
      }
      for (const auto& w : warm_starts()) {
        IntegratorConfig d;
        d.type = row.type;
        d.warm_start = w.value;
        const bool ok = !row.reads(IntegratorOption::warm_start) ||
                        std::find(row.warm_starts.begin(), row.warm_starts.end(), w.value) != row.warm_starts.end();
        if (ok) EXPECT_NO_THROW(make_integrator(d)) << row.key << " " << w.key;
        else EXPECT_THROW(make_integrator(d), std::invalid_argument) << row.key << " " << w.key;
      }
    }
  IntegratorConfig coupled_sweep;
  coupled_sweep.type = IntegratorType::coupled_implicit;
  coupled_sweep.solver = CoupledSolver::sweep;
  EXPECT_THROW(make_integrator(coupled_sweep), std::invalid_argument);
  IntegratorConfig bdf2_previous;
  bdf2_previous.type = IntegratorType::bdf2;
  bdf2_previous.warm_start = WarmStart::previous;
  EXPECT_THROW(make_integrator(bdf2_previous), std::invalid_argument);
}

}  // namespace
}  // namespace qbond
