// The energy ledger's per-step sums (energy_sums.hpp, step_work.hpp) against plain bond-by-bond
// sums: the bonds' energy and the dampers' work, whose affine blocks of eight are one
// vector loop, and the anchors' work, found through the moving prescribed quanta only.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "ledger/energy_sums.hpp"
#include "core/parallel.hpp"
#include "qbond/model/ordering.hpp"
#include "ledger/step_work.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

// A lattice whose bonds mix both laws and both damping models (test::mix_bonds), with plastic
// rest lengths and, if asked, a seventeenth of them broken; perturbed, in the builder's order or
// in scene loading's, where most bonds form affine blocks.
World mixed_lattice(int nx, int ny, int nz, bool grouped, bool broken) {
  World w = test::lattice(nx, ny, nz, 1000, 1e-3, 0.02, true, Vec3(0, 0, -9.81));
  if (grouped) renumber(w, locality_order(w));
  test::mix_bonds(w);
  Rng rng{5};
  for (std::size_t b = 0; b < w.num_bonds(); ++b) {
    w.state.bonds.rest[b] *= 1 + 0.05 * (2 * rng.uniform() - 1);
    if (broken && b % 17 == 5) w.state.bonds.alive[b] = 0;
  }
  test::perturb(w, 2e-3, 0.2);
  return w;
}

// A step's projection with every quanta moving, the prescribed ones too.
Projection random_projection(const World& w, std::uint64_t seed) {
  Projection p;
  p.resize(w.num_quanta());
  Rng rng{seed};
  auto r = [&] { return 2 * rng.uniform() - 1; };
  for (std::size_t i = 0; i < w.num_quanta(); ++i) {
    p.dx[i] = 1e-4 * Vec3(r(), r(), r());
    p.dv[i] = 0.1 * Vec3(r(), r(), r());
  }
  return p;
}

// A sum of n terms of one sign, each correctly rounded to within a few ulps, is within
// (n + 4) ε of the exact sum in relative terms, whatever the order of addition.
double sum_tolerance(std::size_t n, double plain) {
  return static_cast<double>(n + 4) * std::numeric_limits<double>::epsilon() * std::abs(plain);
}

// The state a projection applies, x + Δx and v + Δv (apply_checked's, advance.hpp).
struct Applied {
  std::vector<Vec3> x, v;
  Applied(const State& s, const Projection& p) : x(s.x), v(s.v) {
    for (std::size_t i = 0; i < x.size(); ++i) {
      x[i] += p.dx[i];
      v[i] += p.dv[i];
    }
  }
  AppliedState state() const { return {x, v}; }
};

// Every damper point the kernels tell apart (energy_sums.cpp): θ = 1, 0 or between at the start's
// bond, and the midpoint's θ = φ = ½, and one more of each.
TEST(EnergyLedger, BondSumsMatchThePlainSumsOnARandomLattice) {
  for (bool grouped : {false, true}) {
    for (bool broken : {false, true}) {
      const std::string where =
          std::string(grouped ? "grouped" : "builder's order") + (broken ? ", broken" : "");
      const World w = mixed_lattice(10, 4, 3, grouped, broken);
      const Model& m = w.model;
      const State& s = w.state;
      const Projection p = random_projection(w, 3);
      const Applied a(s, p);
      const double h = 1e-3;
      double energy = 0, energy_after = 0;
      for (std::size_t b = 0; b < w.num_bonds(); ++b) {
        if (!s.bonds.alive[b]) continue;
        const Index i = s.bonds.i[b], j = s.bonds.j[b];
        energy += s.bonds.law_at(m.shapes, b, (s.x[j] - s.x[i]).norm(), s.bonds.rest[b]).U;
        energy_after +=
            s.bonds.law_at(m.shapes, b, ((s.x[j] + p.dx[j]) - (s.x[i] + p.dx[i])).norm(), s.bonds.rest[b]).U;
      }
      ASSERT_GT(energy, 0) << where;
      ASSERT_NE(energy_after, energy) << where;
      EXPECT_NEAR(bond_energy_sum(m, s, 1), energy, sum_tolerance(w.num_bonds(), energy)) << where;
      for (const auto& [theta, phi] :
           {std::pair{1.0, 0.0}, {0.0, 0.0}, {0.5, 0.0}, {0.3, 0.0}, {0.5, 0.5}, {1.0, 1.0}}) {
        const std::string what = where + ", theta " + std::to_string(theta) + ", phi " + std::to_string(phi);
        double damping = 0;
        for (std::size_t b = 0; b < w.num_bonds(); ++b) {
          if (!s.bonds.alive[b]) continue;
          const Index i = s.bonds.i[b], j = s.bonds.j[b];
          const Vec3 d = s.x[j] - s.x[i] + phi * (p.dx[j] - p.dx[i]);
          const Vec3 v = (s.v[j] + theta * p.dv[j]) - (s.v[i] + theta * p.dv[i]);
          const double vu = v.dot(d.normalized());
          damping +=
              h * s.bonds.damping[b] * (s.bonds.damping_model[b] == DampingModel::axial ? vu * vu : v.squaredNorm());
        }
        ASSERT_GT(damping, 0) << what;
        const BondStepSums step = bond_step_sums(m, s, a.state(), h, theta, phi, false, 1);
        EXPECT_NEAR(step.damping, damping, sum_tolerance(w.num_bonds(), damping)) << what;
        EXPECT_NEAR(step.energy_after, energy_after, sum_tolerance(w.num_bonds(), energy_after)) << what;
        EXPECT_EQ(step.step_loss, 0.0) << what;
      }
      // Backward Euler's: Δdᵀ K_c Δd + T₀ u·Δd − (U(d₁) − U(d₀)) with the clamped stiffness block
      // K_c, the tension T₀ and direction u at the start's bond (the lattice's rest lengths
      // compress some bonds); beside it, the quadratic model's ½ Δdᵀ K Δd where nothing is clamped,
      // which differs from it by the third-order terms of the bonds' energy.
      double loss = 0, model_loss = 0, scale = 0;
      for (std::size_t b = 0; b < w.num_bonds(); ++b) {
        if (!s.bonds.alive[b]) continue;
        const Index i = s.bonds.i[b], j = s.bonds.j[b];
        const Vec3 d = s.x[j] - s.x[i], dd = p.dx[j] - p.dx[i];
        const LawValue lv = s.bonds.law_at(m.shapes, b, d.norm(), s.bonds.rest[b]);
        const double u1 = s.bonds.law_at(m.shapes, b, (d + dd).norm(), s.bonds.rest[b]).U;
        const double clamped = dd.dot(stiffness_block(lv.T, lv.dT, d.norm(), d.normalized(), true) * dd);
        loss += clamped + lv.T * d.normalized().dot(dd) - (u1 - lv.U);
        model_loss += clamped - 0.5 * dd.dot(stiffness_block(lv.T, lv.dT, d.norm(), d.normalized(), false) * dd);
        scale += std::abs(lv.U) + std::abs(u1) + clamped;
      }
      ASSERT_GT(model_loss, 0) << where;
      const BondStepSums step = bond_step_sums(m, s, a.state(), h, 1, 0, true, 1);
      EXPECT_NEAR(step.step_loss, loss, sum_tolerance(w.num_bonds(), scale)) << where;
      EXPECT_GT(std::abs(step.step_loss - model_loss), 1e3 * sum_tolerance(w.num_bonds(), scale)) << where;
    }
  }
}

TEST(EnergyLedger, BondSumsGiveTheSameBitsAtAnyThreadCount) {
  // Enough bonds for reduce_chunks to split them among threads, in a world large enough for its
  // bond passes to take them (bond_pass_threads).
  const World w = mixed_lattice(20, 16, 14, true, true);
  ASSERT_GT(w.num_bonds(), 8 * kSumChunk);
  ASSERT_GE(w.num_quanta(), kParallelMin);
  const Projection p = random_projection(w, 4);
  const Applied a(w.state, p);
  const double e1 = bond_energy_sum(w.model, w.state, 1);
  const BondStepSums s1 = bond_step_sums(w.model, w.state, a.state(), 1e-3, 1, 0, true, 1);
  for (int threads : {2, 3}) {
    EXPECT_EQ(bond_energy_sum(w.model, w.state, threads), e1) << threads << " threads";
    const BondStepSums st = bond_step_sums(w.model, w.state, a.state(), 1e-3, 1, 0, true, threads);
    EXPECT_EQ(st.damping, s1.damping) << threads << " threads";
    EXPECT_EQ(st.energy_after, s1.energy_after) << threads << " threads";
    EXPECT_EQ(st.step_loss, s1.step_loss) << threads << " threads";
  }
}

// The anchors' work, by the trapezoid rule, summed over every bond with a prescribed end.
double plain_anchor_work(const Model& m, const State& s, const Projection& p) {
  double work = 0;
  for (std::size_t b = 0; b < s.bonds.size(); ++b) {
    const Index i = s.bonds.i[b], j = s.bonds.j[b];
    const bool ki = m.is_kinematic(i), kj = m.is_kinematic(j);
    if (!s.bonds.alive[b] || (!ki && !kj)) continue;
    const Vec3 d0 = s.x[j] - s.x[i], d1 = d0 + p.dx[j] - p.dx[i];
    const Vec3 w = (s.v[j] + p.dv[j]) - (s.v[i] + p.dv[i]);  // θ = 1, φ = 0
    const double T0 = s.bonds.law_at(m.shapes, b, d0.norm(), s.bonds.rest[b]).T,
                 T1 = s.bonds.law_at(m.shapes, b, d1.norm(), s.bonds.rest[b]).T;
    const Vec3 u0 = d0.normalized();
    Vec3 fi = 0.5 * (T0 * u0 + T1 * d1.normalized());
    fi += s.bonds.damping_model[b] == DampingModel::axial ? Vec3(s.bonds.damping[b] * w.dot(u0) * u0)
                                                          : Vec3(s.bonds.damping[b] * w);
    if (ki) work -= fi.dot(p.dx[i]);
    if (kj) work += fi.dot(p.dx[j]);
  }
  return work;
}

TEST(EnergyLedger, AnchorWorkCountsEveryBondOfAMovingPrescribedQuantaOnce) {
  World w = mixed_lattice(6, 4, 3, true, true);
  // Prescribe a second layer too, so that bonds join prescribed quanta: both moving, one moving.
  std::vector<Index> layer;
  for (std::size_t i = 0; i < w.num_quanta(); ++i)
    if (std::abs(w.state.x[i].x() - 0.01) < 5e-3) layer.push_back(static_cast<Index>(i));
  w.prescribe(layer, Motion{});
  const Model& m = w.model;
  Projection p = random_projection(w, 6);
  // Every third prescribed quanta stays put (an anchor); the others move.
  std::size_t moving = 0, still = 0;
  for (std::size_t i = 0; i < w.num_quanta(); ++i) {
    if (!m.is_kinematic(static_cast<Index>(i))) continue;
    if (i % 3 == 0) {
      p.dx[i] = Vec3::Zero();
      ++still;
    } else {
      ++moving;
    }
  }
  ASSERT_GT(moving, 10u);
  ASSERT_GT(still, 10u);
  Adjacency adj;
  build_adjacency(m, w.state, adj);
  const std::vector<Vec3> f_ext(w.num_quanta(), Vec3::Zero());
  const double plain = plain_anchor_work(m, w.state, p);
  ASSERT_GT(std::abs(plain), 0);
  for (int threads : {1, 2}) {
    const StepWork sw =
        step_work(m, w.state, adj, p, Applied(w.state, p).state(), f_ext, 1e-3, {.damping_theta = 1}, threads);
    EXPECT_NEAR(sw.anchors, plain, 1e-12 * std::abs(plain)) << threads << " threads";
  }
}

}  // namespace
}  // namespace qbond
