// Force laws: every law of the registry checked by finite differences (U' = T, T', the force's
// stiffness and damping blocks on two quanta, the mean tension and its derivative), each law's
// shape, the registry against the docs, and the new laws' limits: FENE past its largest
// extension, the cohesive bond's failure and its softening under implicit steps.
#include <gtest/gtest.h>

#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

#include "integrators/bond_forces.hpp"
#include "qbond/heuristics/fracture.hpp"
#include "qbond/laws/laws.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

constexpr double kRound = std::numeric_limits<double>::epsilon();

struct LawCase {
  Law law;
  double L;
  LawArgs a;
  double scale;           // the shortest length over which the law's tension changes [m]
  std::vector<double> s;  // stretches r − L to test at, in units of `scale`, ≥ 0.1 from any kink
};

std::vector<LawCase> law_cases() {
  const std::vector<double> around = {-0.5, -3.0, -1.0, -0.3, 0.2, 1.0, 2.5, 8.0};
  return {
      {Law::linear, 1.0, {.strength = 250.0}, 0.05, around},
      {Law::inverse, 1.0, {.strength = 3.0, .shape = {0.05, 0}}, 0.05, around},
      {Law::inverse, 0.02, {.strength = 0.7, .shape = {0.001, 0}}, 0.001, around},
      // eps defaulted: 0.05 of the rest length the bond was made with.
      {Law::inverse, 0.5, {.strength = 0.7, .rest0 = 0.5}, 0.025, around},
      // Morse: the largest tension at s = ln 2/α (T' = 0 there), compression, the fading tail.
      {Law::morse, 1.0, {.strength = 2.0, .shape = {8.0, 0}}, 1 / 8.0, {-0.5, -0.2, 0.0, 0.3, std::log(2.0), 1.0, 3.0, 6.0}},
      // FENE, R0 = 20 scale: inside, near ±0.95 R0 = ±19 scale on both sides, and on the continuation.
      {Law::fene, 1.0, {.strength = 100.0, .shape = {0.2, 0}}, 0.01, {-25.0, -19.5, -10.0, -1.0, 0.0, 3.0, 15.0, 18.9, 19.1, 30.0}},
      // Cohesive, s_p = 1 scale and s_f = 5 scale: loading, compression, softening, failed.
      {Law::cohesive, 1.0, {.strength = 500.0, .shape = {0.01, 0.05}}, 0.01, {-2.0, -0.5, 0.0, 0.5, 0.9, 1.5, 3.0, 4.9, 5.5, 8.0}},
  };
}

LawValue at(const LawCase& c, double r) { return evaluate_law(c.law, r, c.L, c.a); }
double rest_k(const LawCase& c) { return rest_stiffness(c.law, c.a); }

// Central differences with step d = 1e-4 ℓ (ℓ the case's scale): truncation f''' d²/6, with
// f''' ~ f'/ℓ², is 1.7e-9 of f'; round-off u f/d, with f ~ f' ℓ, is 2.2e-12 of it. The bound is
// a hundred times their sum (f''' reaches several f'/ℓ² where these laws curve most), taken
// against the law's own scale where a value crosses zero: the stiffness at rest, and that times ℓ.
constexpr double kStep = 1e-4;
constexpr double kTol = 100 * (kStep * kStep / 6 + kRound / kStep);

TEST(Laws, PotentialDerivativeIsTension) {
  for (const LawCase& c : law_cases())
    for (double s : c.s) {
      const double r = c.L + s * c.scale, d = kStep * c.scale, k0 = rest_k(c);
      const double dU = (at(c, r + d).U - at(c, r - d).U) / (2 * d);
      const LawValue lv = at(c, r);
      EXPECT_NEAR(dU, lv.T, kTol * std::max(std::abs(lv.T), k0 * c.scale)) << to_string(c.law) << " s=" << s;
      const double dT = (at(c, r + d).T - at(c, r - d).T) / (2 * d);
      EXPECT_NEAR(dT, lv.dT, kTol * std::max(std::abs(lv.dT), k0)) << to_string(c.law) << " s=" << s;
      EXPECT_EQ(at(c, c.L).U, 0.0) << to_string(c.law);  // U(L) = 0
    }
}

TEST(Laws, InverseLawShape) {
  // Slope F/eps² at rest, peak F/(2 eps) at |r - L| = eps, and Eq. 3's F/(r - L) far away.
  const double F = 2.0, L = 1.0, eps = 0.01;
  const LawArgs a{.strength = F, .shape = {eps, 0}};
  EXPECT_DOUBLE_EQ(evaluate_law(Law::inverse, L, L, a).dT, F / (eps * eps));
  EXPECT_DOUBLE_EQ(evaluate_law(Law::inverse, L + eps, L, a).T, F / (2 * eps));
  EXPECT_NEAR(evaluate_law(Law::inverse, L + eps, L, a).dT, 0.0, 1e-9);
  const double far = 100 * eps;
  EXPECT_NEAR(evaluate_law(Law::inverse, L + far, L, a).T, F / far, 1e-4 * F / far);
  // The default eps is 0.05 of the rest length the bond was made with.
  EXPECT_EQ(InverseLaw::eps({.strength = F, .rest0 = 0.4}), kDefaultInverseEpsFraction * 0.4);
}

TEST(Laws, MorseLawShape) {
  // Stiffness 2 D0 α² at rest, the largest tension D0 α/2 at s = ln 2/α, U → D0 far away.
  const double D0 = 3.0, alpha = 5.0, L = 0.7;
  const LawArgs a{.strength = D0, .shape = {alpha, 0}};
  EXPECT_DOUBLE_EQ(evaluate_law(Law::morse, L, L, a).dT, 2 * D0 * alpha * alpha);
  EXPECT_DOUBLE_EQ(rest_stiffness(Law::morse, a), 2 * D0 * alpha * alpha);
  const LawValue peak = evaluate_law(Law::morse, L + std::log(2.0) / alpha, L, a);
  EXPECT_NEAR(peak.T, D0 * alpha / 2, 1e-15 * D0 * alpha);
  EXPECT_NEAR(peak.dT, 0.0, 1e-14 * D0 * alpha * alpha);
  EXPECT_NEAR(evaluate_law(Law::morse, L + 40 / alpha, L, a).U, D0, 1e-15 * D0);
}

TEST(Laws, FeneIsFiniteAndSmoothPastItsLargestExtension) {
  const double K = 50.0, R0 = 0.3, L = 1.0, c = FeneLaw::kFeneLinearFrom * R0;
  const LawArgs a{.strength = K, .shape = {R0, 0}};
  // Inside: T = K s / (1 − (s/R0)²), U = −½ K R0² ln(1 − (s/R0)²).
  for (double s : {-0.9 * c, -0.2 * c, 0.5 * c, c}) {
    const LawValue v = evaluate_law(Law::fene, L + s, L, a);
    EXPECT_NEAR(v.T, K * s / (1 - (s / R0) * (s / R0)), 1e-14 * std::abs(v.T));
    EXPECT_NEAR(v.U, -0.5 * K * R0 * R0 * std::log(1 - (s / R0) * (s / R0)), 1e-14 * v.U);
  }
  // Across ±0.95 R0, T, T' and U are continuous (the continuation is the tangent there) ...
  for (double sign : {-1.0, 1.0}) {
    const double h = 1e-9 * R0;
    const LawValue in = evaluate_law(Law::fene, L + sign * (c - h), L, a);
    const LawValue out = evaluate_law(Law::fene, L + sign * (c + h), L, a);
    EXPECT_NEAR(in.T, out.T, 1e-6 * std::abs(in.T));
    EXPECT_NEAR(in.dT, out.dT, 1e-6 * in.dT);
    EXPECT_NEAR(in.U, out.U, 1e-6 * in.U);
    // ... and at R0 and far past it everything stays finite, the tension growing with the stretch.
    double last = 0;
    for (double s : {R0, 2 * R0, 10 * R0}) {
      const LawValue v = evaluate_law(Law::fene, L + sign * s, L, a);
      EXPECT_TRUE(std::isfinite(v.T) && std::isfinite(v.dT) && std::isfinite(v.U));
      EXPECT_GT(sign * v.T, last);
      last = sign * v.T;
      const MeanTension m = mean_tension(Law::fene, L, L + sign * s, L, a);
      EXPECT_TRUE(std::isfinite(m.T) && std::isfinite(m.dT1));
    }
  }
}

TEST(Laws, CohesiveLawShape) {
  const double k = 400.0, L = 2.0, ep = 0.01, ef = 0.04, sp = ep * L, sf = ef * L;
  const LawArgs a{.strength = k, .shape = {ep, ef}};
  EXPECT_DOUBLE_EQ(evaluate_law(Law::cohesive, L + sp, L, a).T, k * sp);  // the peak
  EXPECT_NEAR(evaluate_law(Law::cohesive, L - 3 * sp, L, a).T, -3 * k * sp, 1e-14 * k * sp);  // linear compression
  EXPECT_NEAR(evaluate_law(Law::cohesive, L + 0.5 * (sp + sf), L, a).T, 0.5 * k * sp, 1e-14 * k * sp);
  EXPECT_DOUBLE_EQ(evaluate_law(Law::cohesive, L + sf, L, a).T, 0.0);
  // U at failure and beyond is the fracture energy G = k s_p s_f / 2, the area under T.
  EXPECT_DOUBLE_EQ(evaluate_law(Law::cohesive, L + sf, L, a).U, 0.5 * k * sp * sf);
  EXPECT_DOUBLE_EQ(evaluate_law(Law::cohesive, L + 5 * sf, L, a).U, 0.5 * k * sp * sf);
  EXPECT_DOUBLE_EQ(failure_stretch(Law::cohesive, L, a), sf);
  EXPECT_EQ(failure_stretch(Law::linear, L, a), std::numeric_limits<double>::infinity());
  EXPECT_TRUE(invalid_law_shape(Law::cohesive, {ep, ef}).empty());
  EXPECT_FALSE(invalid_law_shape(Law::cohesive, {ef, ep}).empty());  // failure before the peak
  EXPECT_FALSE(invalid_law_shape(Law::fene, {0, 0}).empty());        // R0 is required
  EXPECT_TRUE(invalid_law_shape(Law::inverse, {0, 0}).empty());      // eps has a default
}

// A bond of case c between two quanta, with damping model dm and damping D.
World two_quanta(const LawCase& c, DampingModel dm, double D) {
  World w;
  w.add_quanta(Vec3::Zero(), Vec3::Zero(), 1.0);
  w.add_quanta(Vec3(c.L, 0, 0), Vec3::Zero(), 1.0);
  w.add_bond(0, 1, {.law = c.law, .stiffness = c.a.strength, .damping = D, .damping_model = dm, .rest_length = c.L,
                    .shape = c.a.shape});
  return w;
}

TEST(Laws, StiffnessAndDampingBlocksMatchFiniteDifferences) {
  // K_b and C_b of a two-quanta system against central differences of the model's bond force
  // (steps and bound as PotentialDerivativeIsTension's; the velocity step is exact: the force
  // is linear in the velocities).
  Rng rng{3};
  auto rnd = [&] { return Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5); };
  for (const LawCase& c : law_cases())
    for (DampingModel dm : {DampingModel::axial, DampingModel::isotropic}) {
      const double D = 0.3;
      const World w = two_quanta(c, dm, D);
      const Model& m = w.model;
      const Bonds& bonds = w.state.bonds;
      auto force_i = [&](const Vec3& xi, const Vec3& xj, const Vec3& vi, const Vec3& vj) {
        return bonds.force_on_i(m.shapes, 0, xj - xi, vj - vi, c.L);
      };
      for (double s : c.s) {
        const double r = c.L + s * c.scale;
        const Vec3 xi = rnd(), vi = rnd(), vj = rnd();
        const Vec3 u = rnd().normalized();
        const Vec3 xj = xi + r * u;
        const LawValue lv = bonds.law_at(m.shapes, 0, r, c.L);
        EXPECT_EQ(lv.T, at(c, r).T);  // the model's law is the case's
        const Mat3 K = stiffness_block(lv.T, lv.dT, r, u, /*clamp_for_solver=*/false);
        const Mat3 C = damping_block(dm, D, u);
        Mat3 dfi_dxj, dfi_dxi, dfi_dvj, dfi_dvi;
        const double hx = kStep * c.scale, hv = 1e-3;
        // The damping force of the axial model turns with u, so it adds d(D (w·u) u)/dx to the
        // position Jacobian; K_b is the elastic part only: difference positions at w = 0.
        const Vec3 vjx = dm == DampingModel::axial ? vi : vj;
        for (int k = 0; k < 3; ++k) {
          const Vec3 e = Vec3::Unit(k);
          dfi_dxj.col(k) = (force_i(xi, xj + hx * e, vi, vjx) - force_i(xi, xj - hx * e, vi, vjx)) / (2 * hx);
          dfi_dxi.col(k) = (force_i(xi + hx * e, xj, vi, vjx) - force_i(xi - hx * e, xj, vi, vjx)) / (2 * hx);
          dfi_dvj.col(k) = (force_i(xi, xj, vi, vj + hv * e) - force_i(xi, xj, vi, vj - hv * e)) / (2 * hv);
          dfi_dvi.col(k) = (force_i(xi, xj, vi + hv * e, vj) - force_i(xi, xj, vi - hv * e, vj)) / (2 * hv);
        }
        const double kn = std::max(K.norm(), rest_k(c)), cn = C.norm();
        EXPECT_LE((dfi_dxj - K).norm(), kTol * kn) << to_string(c.law) << " s=" << s;
        EXPECT_LE((dfi_dxi + K).norm(), kTol * kn) << to_string(c.law) << " s=" << s;
        EXPECT_LE((dfi_dvj - C).norm(), kTol * cn) << to_string(dm);
        EXPECT_LE((dfi_dvi + C).norm(), kTol * cn) << to_string(dm);
      }
    }
}

// The discrete-gradient mean tension of every law, from each test length over steps dr long and
// short, crossing the laws' kinks (cohesive s_p and s_f, FENE ±0.95 R0) and all of them at once:
//  - exactness: T̄ dr = U(r1) − U(r0) up to the round-off of the two energies and of T̄ itself (a
//    few ulps each; 64 allows for the laws' dozen operations);
//  - the limit: T̄ → T(r̄) for |dr| ≤ 1e-6 ℓ, T̄ − T(r̄) = T'' dr²/24 with T'' ~ T'/ℓ;
//  - ∂T̄/∂r1 against central differences in r1 with step 1e-4 ℓ: truncation 1.7e-9 of T', round-off
//    2e-12; the laws' own ∂T̄/∂r1 is the quotient (T(r1) − T̄)/dr (round-off u ℓ/dr ≤ 2e-11 of
//    T') or, below dr = 1e-5 ℓ, its limit T'(r̄)/2, off by T'' dr/12 ≤ 1e-6 T'.
TEST(Laws, MeanTensionIsTheExactEnergyQuotient) {
  for (const LawCase& c : law_cases())
    for (double s : c.s)
      for (double ds : {2.37, -1.31, 6.77, 41.3, 1e-3, 1e-6, -1e-9, 1e-12}) {
        const double r0 = c.L + s * c.scale, r1 = r0 + ds * c.scale, dr = r1 - r0;  // dr as stored
        const MeanTension m = mean_tension(c.law, r0, r1, c.L, c.a);
        const LawValue v0 = at(c, r0), v1 = at(c, r1);
        const double Tmax = std::max({std::abs(v0.T), std::abs(v1.T), std::abs(m.T)});
        const double kref = std::max({rest_k(c), std::abs(v0.dT), std::abs(v1.dT)});
        // Lengths are stored to u r: a mean length (r0 + r1)/2 is off by up to u r, T by kref u r.
        const double Tround = 64 * kRound * Tmax + kref * kRound * r1;
        EXPECT_NEAR(m.T * dr, v1.U - v0.U, 64 * kRound * (std::abs(v0.U) + std::abs(v1.U)) + Tround * std::abs(dr))
            << to_string(c.law) << " s=" << s << " ds=" << ds;
        if (std::abs(ds) <= 1e-6) {
          EXPECT_NEAR(m.T, at(c, 0.5 * (r0 + r1)).T, 10 * kref * dr * dr / c.scale + 2 * Tround)
              << to_string(c.law) << " s=" << s << " ds=" << ds;
        }
        const double h = kStep * c.scale;
        const double fd = (mean_tension(c.law, r0, r1 + h, c.L, c.a).T - mean_tension(c.law, r0, r1 - h, c.L, c.a).T) / (2 * h);
        EXPECT_NEAR(m.dT1, fd, 1e-6 * kref) << to_string(c.law) << " s=" << s << " ds=" << ds;
      }
}

TEST(Laws, RegistryNamesRoundTrip) {
  ASSERT_EQ(all_laws().size(), static_cast<std::size_t>(kNumLaws));
  for (const LawInfo& l : all_laws()) {
    EXPECT_EQ(parse_law(l.name), l.law);
    EXPECT_EQ(to_string(l.law), l.name);
    EXPECT_TRUE(is_law_id(static_cast<std::uint8_t>(l.law)));
    EXPECT_LE(l.shape.size(), kMaxLawShape);
  }
  EXPECT_FALSE(parse_law("hooke").has_value());
  EXPECT_FALSE(is_law_id(kNumLaws));
}

TEST(Laws, SceneFormatDocsListEveryLawAndItsKeys) {
  // docs/scene-format.md has a row "| `law` | `key` |" for each parameter of each law.
  std::ifstream f(std::string(QBOND_SOURCE_DIR) + "/docs/scene-format.md");
  ASSERT_TRUE(f.good());
  std::stringstream text;
  text << f.rdbuf();
  const std::string doc = text.str();
  for (const LawInfo& l : all_laws()) {
    std::vector<std::string_view> keys = {l.strength.key};
    if (l.calibrated_by_modulus) keys.push_back("youngs_modulus");
    for (const LawParam& p : l.shape) keys.push_back(p.key);
    for (std::string_view k : keys) {
      const std::string row = "| `" + std::string(l.name) + "` | `" + std::string(k) + "` |";
      EXPECT_NE(doc.find(row), std::string::npos)
          << "docs/scene-format.md lacks the row " << row << "; regenerate: build/qbond key-tables docs/scene-format.md docs/heuristics.md";
    }
  }
}

// Three quanta in a row on two cohesive bonds: the first anchored, the last pulled away at speed
// v, the middle one free.
World cohesive_bar(double k, double ep, double ef, double v) {
  World w;
  for (int i = 0; i < 3; ++i) w.add_quanta(Vec3(i, 0, 0), Vec3::Zero(), 1e-3);
  for (Index i = 0; i < 2; ++i)
    w.add_bond(i, i + 1, {.law = Law::cohesive, .stiffness = k, .damping = 0.01, .shape = {ep, ef}});
  w.prescribe({0}, Motion{});
  Motion pull;
  pull.type = MotionType::translate;
  pull.velocity = Vec3(v, 0, 0);
  w.prescribe({2}, pull);
  return w;
}

TEST(Laws, CohesiveBondBreaksAtItsFailureStretchWithoutAHeuristic) {
  // A world built through the API, no heuristic: pulled past the peak, one bond softens and takes
  // the stretch until it reaches s_f, where the step itself breaks it: an event with reason
  // `failure`, its fracture energy G charged to the ledger as dissipated, no step refused by the
  // energy checks, and the bond stays broken.
  const double k = 100.0, ep = 0.01, ef = 0.05, G = 0.5 * k * ep * ef;
  Simulation sim(cohesive_bar(k, ep, ef, 0.02), test::config(IntegratorType::energy_momentum), 1e-3);
  std::vector<BondEvent> events;
  for (int n = 0; n < 8000 && events.empty(); ++n) {
    ASSERT_EQ(sim.step().status, StepReport::Status::ok) << "step " << n;
    events = sim.events();
  }
  ASSERT_EQ(events.size(), 1u);
  const BondEvent& e = events[0];
  EXPECT_EQ(e.reason, BondEvent::Reason::failure);
  EXPECT_GE(e.strain, ef);
  EXPECT_EQ(e.tension, 0.0);
  const World& w = sim.world();
  EXPECT_EQ(w.state.bonds.alive[e.bond], 0);
  EXPECT_EQ(w.state.bonds.alive[1 - e.bond], 1);
  EXPECT_DOUBLE_EQ(w.state.energy.dissipated_heuristics, G);
  for (int n = 0; n < 200; ++n) sim.step();  // the pull goes on: the broken bond stays broken
  EXPECT_EQ(sim.world().state.bonds.alive[e.bond], 0);
}

TEST(Laws, CohesiveBondFailsWhateverTheBreakRuleSelects) {
  // A break rule whose selection holds no quanta leaves the bonds alone, but not their failure:
  // the step breaks the bond at s_f all the same, reason `failure`.
  const double k = 100.0, ep = 0.01, ef = 0.05;
  Simulation sim(cohesive_bar(k, ep, ef, 0.02), test::config(IntegratorType::energy_momentum), 1e-3);
  sim.add_heuristic(make_heuristic(BreakRule{.max_strain = 0.001, .quanta = {0, 0, 0}}));
  std::vector<BondEvent> events;
  for (int n = 0; n < 8000 && events.empty(); ++n) {
    sim.step();
    events = sim.events();
  }
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].reason, BondEvent::Reason::failure);
  EXPECT_GE(events[0].strain, ef);
  EXPECT_DOUBLE_EQ(sim.world().state.energy.dissipated_heuristics, 0.5 * k * ep * ef);
}

TEST(Laws, CohesiveBondBreaksWhenTheStepWouldAdvanceInPlace) {
  // Velocity Verlet without the ledger advances a step in place when nothing edits it; bonds that
  // can fail keep the step projected, so the failure stage sees it: the bond breaks once, at s_f.
  const double k = 100.0, ep = 0.01, ef = 0.05;
  Simulation sim(cohesive_bar(k, ep, ef, 0.02), test::config(IntegratorType::velocity_verlet), 1e-3);
  sim.set_track_energy(false);
  std::vector<BondEvent> events;
  for (int n = 0; n < 8000 && events.empty(); ++n) {
    ASSERT_EQ(sim.step().status, StepReport::Status::ok) << "step " << n;
    events = sim.events();
  }
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].reason, BondEvent::Reason::failure);
  EXPECT_GE(events[0].strain, ef);
  EXPECT_DOUBLE_EQ(sim.world().state.energy.dissipated_heuristics, 0.5 * k * ep * ef);
}

TEST(Laws, SofteningBondUnderImplicitSteps) {
  // One free quanta on a cohesive bond, released from rest on the softening branch. The solvers
  // clamp the negative T' at 0 (stiffness_block); the Newton integrators still converge on the
  // exact forces, at a step whose unclamped Jacobian m/h² + T' would be negative (m/h² = 100 N/m,
  // T' = −1000 N/m). energy_momentum keeps the energy (the discrete gradient of U) to its Newton
  // tolerance, bdf2 and the linearised backward Euler (coupled_implicit, at a step it resolves:
  // k h²/m = 1.6) lose some; each pulls the quanta back onto the loading branch.
  const double k = 1000.0, L = 1.0, ep = 0.01, ef = 0.02, s0 = 0.015;
  struct Run {
    IntegratorType type;
    double h;
  };
  for (const Run run : {Run{IntegratorType::energy_momentum, 0.1}, Run{IntegratorType::bdf2, 0.1},
                        Run{IntegratorType::coupled_implicit, 0.04}}) {
    World w;
    w.add_quanta(Vec3::Zero(), Vec3::Zero(), 0.0);
    w.add_quanta(Vec3(L + s0, 0, 0), Vec3::Zero(), 1.0);
    w.add_bond(0, 1, {.law = Law::cohesive, .stiffness = k, .rest_length = L, .shape = {ep, ef}});
    if (run.type != IntegratorType::coupled_implicit) {
      ASSERT_LT(w.state.bonds.law_at(w.model.shapes, 0, L + s0, L).dT, -1.0 / (run.h * run.h));
    }
    const double E0 = energies(w.model, w.state).total();
    IntegratorConfig config = test::config(run.type);
    config.tolerance = 1e-12;
    // Newton with the clamped Jacobian converges only linearly on the softening branch and at the
    // kink; enough iterations that every step is solved whole, whatever the build's rounding.
    config.newton_iterations = 200;
    Simulation sim(std::move(w), config, run.h);
    double r_min = L + s0;
    for (int n = 0; n < 30; ++n) {
      sim.step();
      const World& ws = sim.world();
      const double r = (ws.state.x[1] - ws.state.x[0]).norm();
      ASSERT_TRUE(std::isfinite(r));
      r_min = std::min(r_min, r);
      const double E = energies(ws.model, ws.state).total();
      if (run.type == IntegratorType::energy_momentum) {
        ASSERT_EQ(sim.integrator().stats().substeps, 0) << "step " << n;
        EXPECT_NEAR(E, E0, 1e-9 * E0) << "step " << n;
      } else {
        EXPECT_LE(E, E0 * (1 + 1e-9)) << to_string(run.type) << " step " << n;
      }
      EXPECT_LT(r - L, ef * L);  // it never reaches failure
    }
    EXPECT_LT(r_min - L, ep * L) << to_string(run.type);  // back on the loading branch
  }
}

TEST(Laws, IsotropicDampingIsEquationTwoLiterally) {
  // Eq. 2's damping term on A is -D (v_A - v_B): the relative velocity, not only its axial part.
  const Vec3 d(1, 0, 0), w(0.2, -0.4, 0.7);
  const Vec3 f = bond_force_on_i(Law::linear, DampingModel::isotropic, d, w, 1.0, 0.5, {.strength = 10.0});
  EXPECT_EQ(f, Vec3(0.5 * w));
  const Vec3 fa = bond_force_on_i(Law::linear, DampingModel::axial, d, w, 1.0, 0.5, {.strength = 10.0});
  EXPECT_EQ(fa, Vec3(0.5 * 0.2, 0, 0));
}

TEST(Laws, ClampedBlockIsPositiveSemiDefinite) {
  const Vec3 u = Vec3(1, 2, 3).normalized();
  // Compressed linear bond: T < 0 makes the transverse term negative.
  const LawValue lv = evaluate_law(Law::linear, 0.8, 1.0, {.strength = 100.0});
  const Mat3 exact = stiffness_block(lv.T, lv.dT, 0.8, u, false);
  const Mat3 clamped = stiffness_block(lv.T, lv.dT, 0.8, u, true);
  EXPECT_LT(Eigen::SelfAdjointEigenSolver<Mat3>(exact).eigenvalues().minCoeff(), 0.0);
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Mat3>(clamped).eigenvalues().minCoeff(), -1e-12);
  EXPECT_NEAR((clamped * u - exact * u).norm(), 0.0, 1e-12);  // the axial stiffness is kept
}

TEST(Laws, ZeroLengthBondExertsNoForce) {
  const Vec3 f = bond_force_on_i(Law::linear, DampingModel::axial, Vec3::Zero(), Vec3(1, 0, 0), 1.0, 1, {.strength = 10});
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
    part.update(w.model, w.state.bonds, adj, 1);
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
