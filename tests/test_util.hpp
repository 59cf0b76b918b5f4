#pragma once
// Small scenes and helpers shared by the tests.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "qbond/analysis/analysis.hpp"
#include "qbond/builders/builders.hpp"
#include "qbond/integrators/integrators.hpp"
#include "qbond/simulation/simulation.hpp"

namespace qbond::test {

// Two quanta of mass m on one linear bond along x, stretched by s0 from rest length L, with
// relative velocity w0 along the bond. Relative motion is harmonic with ω = sqrt(2k/m).
inline World two_quanta(double m, double k, double L, double s0, double w0, double D = 0) {
  World w;
  w.add_quanta(Vec3(0, 0, 0), Vec3(-0.5 * w0, 0, 0), m);
  w.add_quanta(Vec3(L + s0, 0, 0), Vec3(0.5 * w0, 0, 0), m);
  w.add_bond(0, 1, {.law = Law::linear, .stiffness = k, .damping = D, .rest_length = L});
  return w;
}

// A simple-cubic block (face diagonals), optionally anchored on its x = 0 face.
inline World lattice(int nx, int ny, int nz, double k, double m, double D, bool anchored,
                     Vec3 gravity = Vec3::Zero(), Law law = Law::linear) {
  World w;
  w.model.gravity = gravity;
  CubicLattice lat;
  lat.size = {nx, ny, nz};
  lat.spacing = 0.01;
  lat.quanta_mass = m;
  lat.bond = {.law = law, .stiffness = k, .damping = D};
  const auto ids = add_cubic_lattice(w, lat);
  if (anchored) {
    std::vector<Index> face;
    for (Index i : ids)
      if (w.state.x[i].x() == 0.0) face.push_back(i);
    w.prescribe(face, Motion{});
  }
  return w;
}

// Mixes a lattice's bonds so that the bond kernels meet every case: on the second half, every third
// bond takes the inverse law (strength F = k ε²: the same slope at rest as the linear ones);
// isotropic damping on the first quarter and on every fourth bond of the second half, axial
// elsewhere. The first half then has runs of one law and damping model (the vector paths), the
// second half mixed ones.
inline void mix_bonds(World& w) {
  const std::size_t nb = w.num_bonds();
  Bonds& bonds = w.state.edit_bonds();
  for (std::size_t b = 0; b < nb; ++b) {
    if (b % 3 == 0 && 2 * b >= nb) {
      bonds.law[b] = Law::inverse;
      const double eps = InverseLaw::eps(bonds.law_args(w.model.shapes, b));
      bonds.strength[b] *= eps * eps;
    }
    if (4 * b < nb || (2 * b >= nb && b % 4 == 0)) bonds.damping_model[b] = DampingModel::isotropic;
  }
}

// Deterministic pseudo-random perturbation of positions (± dx) and velocities (± dv) of free quanta.
inline void perturb(World& w, double dx, double dv, std::uint64_t seed = 7) {
  Rng rng{seed};
  auto r = [&] { return 2 * rng.uniform() - 1; };
  for (std::size_t i = 0; i < w.num_quanta(); ++i) {
    if (w.model.is_kinematic(static_cast<Index>(i))) continue;
    w.state.x[i] += dx * Vec3(r(), r(), r());
    w.state.v[i] += dv * Vec3(r(), r(), r());
  }
}

inline IntegratorConfig config(IntegratorType t) {
  IntegratorConfig c;
  c.type = t;
  return c;
}
inline IntegratorConfig hybrid(NeighbourModel nm, int iterations = 1) {
  IntegratorConfig c;
  c.type = IntegratorType::hybrid_implicit;
  c.neighbours = nm;
  c.iterations = iterations;
  return c;
}
inline IntegratorConfig coupled(CoupledSolver s, double tol = 1e-8) {
  IntegratorConfig c;
  c.type = IntegratorType::coupled_implicit;
  c.solver = s;
  c.tolerance = tol;
  return c;
}

// One integrator for each kind of carry-over (State::carry): velocity Verlet's forces, BDF2's
// history, and CG's last solution (`previous`) and last two (`extrapolated`).
inline std::vector<std::pair<std::string, IntegratorConfig>> carrying_integrators() {
  IntegratorConfig bdf2 = coupled(CoupledSolver::cg, 1e-10);
  bdf2.type = IntegratorType::bdf2;
  IntegratorConfig previous = coupled(CoupledSolver::cg), extrapolated = previous;
  previous.warm_start = WarmStart::previous;
  extrapolated.warm_start = WarmStart::extrapolated;
  return {{"velocity_verlet", config(IntegratorType::velocity_verlet)},
          {"bdf2", bdf2},
          {"cg_previous", previous},
          {"cg_extrapolated", extrapolated}};
}

// Projects one step of `w` with `cfg` (no heuristics), without applying it.
inline Projection project_once(const World& w, const IntegratorConfig& cfg, double h) {
  Simulation sim(w, cfg, h);
  sim.begin_step();
  return sim.projection();
}

// Positions and velocities of two states equal bit for bit (a resumed run against the original).
inline void expect_same_bits(const State& a, const State& b) {
  ASSERT_EQ(a.x.size(), b.x.size());
  EXPECT_EQ(std::memcmp(a.x.data(), b.x.data(), a.x.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(a.v.data(), b.v.data(), a.v.size() * sizeof(Vec3)), 0);
}

// The largest norm of a[i] − b[i] (of a[i]); NaN if one is NaN (std::max would pass it over,
// and a check of the result against a tolerance would then pass).
inline double max_norm_diff(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  double d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double e = (a[i] - b[i]).norm();
    if (std::isnan(e)) return e;
    d = std::max(d, e);
  }
  return d;
}
inline double max_norm(const std::vector<Vec3>& a) { return max_norm_diff(a, std::vector<Vec3>(a.size(), Vec3::Zero())); }

}  // namespace qbond::test
