// The bond-centric passes (bond_partition.hpp) against plain serial loops over the bonds.
#include <gtest/gtest.h>

#include <cstring>
#include <set>
#include <tuple>

#include "integrators/affine_run_terms.hpp"
#include "integrators/bond_partition.hpp"
#include "integrators/bond_forces.hpp"
#include "integrators/backward_euler.hpp"
#include "qbond/model/ordering.hpp"
#include "qbond/core/rng.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

// A lattice past kParallelMin quanta (so that two threads get two ranges), anchored at one face,
// perturbed, with mixed laws and damping models and a random tenth of its bonds broken; grouped:
// renumbered first, as scenes load (ordering.hpp), so that most of its bonds form affine runs.
World random_lattice(bool grouped = false) {
  World w = test::lattice(17, 16, 16, 1000, 1e-3, 0.02, true);
  if (grouped) renumber(w, locality_order(w));
  Rng rng{5};
  Bonds& bonds = w.state.edit_bonds();
  for (std::size_t b = 0; b < w.num_bonds(); ++b) {
    if (b % 3 == 0) {
      bonds.law[b] = Law::inverse;
      const double eps = InverseLaw::eps(bonds.law_args(w.model.shapes, b));
      bonds.strength[b] *= eps * eps;
    }
    if (b % 4 == 0) bonds.damping_model[b] = DampingModel::isotropic;
    if (rng.uniform() < 0.1) w.state.break_bond(static_cast<Index>(b));
  }
  test::perturb(w, 2e-3, 0.2);
  return w;
}

// What the passes see: for_each_bond owns each end of each alive bond exactly once, whether it
// walks the per-part lists or (one part, no broken bond) the bonds themselves; and so do the runs
// of for_each_bond_run, in the builder's bond order (no affine runs) and in the offset-grouped
// order scenes load in (ordering.hpp: mostly affine runs, the same runs for every partition).
TEST(BondPartition, ForEachBondOwnsEachEndOfEachAliveBondOnce) {
  const World intact = test::lattice(17, 16, 16, 1000, 1e-3, 0.02, true), broken = random_lattice();
  World grouped_intact = intact;
  renumber(grouped_intact, locality_order(grouped_intact));
  const World grouped_broken = random_lattice(true);
  for (const World* w : {&intact, &broken, static_cast<const World*>(&grouped_intact), &grouped_broken}) {
    const bool grouped = w == &grouped_intact || w == &grouped_broken;
    const bool all_alive = w == &intact || w == &grouped_intact;
    const Model& m = w->model;
    const State& s = w->state;
    Adjacency adj;
    build_adjacency(m, s, adj);
    std::set<std::tuple<Index, Index, Index, Index, bool>> one_part_runs;
    for (int threads : {1, 2, 3}) {
      const std::string what = std::to_string(threads) + " threads" + (grouped ? ", grouped" : "") +
                               (all_alive ? "" : ", broken bonds");
      BondPartition part;
      part.update(m, s.bonds, adj, threads);
      EXPECT_EQ(part.all_in_one, threads == 1 && all_alive) << what;
      std::vector<int> owned_i(w->num_bonds(), 0), owned_j(w->num_bonds(), 0);
      for_each_bond(part, s.bonds, [&](Index b, bool own_i, bool own_j) {
        if (own_i) ++owned_i[b];  // only the call owning an end writes its counter
        if (own_j) ++owned_j[b];
      });
      for (std::size_t b = 0; b < w->num_bonds(); ++b) {
        ASSERT_EQ(owned_i[b], w->state.bonds.alive[b]) << "bond " << b << ", " << what;
        ASSERT_EQ(owned_j[b], w->state.bonds.alive[b]) << "bond " << b << ", " << what;
      }
      // The same in runs (for_each_bond_run): each part's runs in increasing bond order, its last
      // run marked once; an affine run's bonds alive with ends i0 + k and j0 + k.
      struct Seen {
        Index next = 0;
        int lasts = 0;
      };
      std::vector<int> run_i(w->num_bonds(), 0), run_j(w->num_bonds(), 0);
      std::size_t affine = 0;  // bonds in affine runs, over all parts (serial: parts' counters race)
      for (const BondRun& run : part.runs)
        if (run.affine) affine += run.count;
      for_each_bond_run<Seen>(part, [&](const BondRun& run, Seen& seen) {
        EXPECT_LE(run.count, kBondRun);
        for (Index k = 0; k < run.count; ++k) {
          const Index b = run.bond(k);
          EXPECT_GE(b, seen.next);
          seen.next = b + 1;
          if (run.affine) {
            EXPECT_TRUE(w->state.bonds.alive[b]);
            EXPECT_EQ(s.bonds.i[b], run.i0 + k);
            EXPECT_EQ(s.bonds.j[b], run.j0 + k);
          }
          if (run.owns(s.bonds.i[b])) ++run_i[b];
          if (run.owns(s.bonds.j[b])) ++run_j[b];
        }
        if (run.last) {
          EXPECT_EQ(++seen.lasts, 1);
        }
      });
      EXPECT_EQ(run_i, owned_i) << what;
      EXPECT_EQ(run_j, owned_j) << what;
      if (grouped)  // a tenth broken leaves about two thirds of the bonds in runs of 8 or more
        EXPECT_GT(affine, (all_alive ? 9 : 5) * w->num_bonds() / 10) << what;
      else
        EXPECT_EQ(affine, 0u) << what;
      // Every partition cuts the segments into the same affine runs (the frozen step picks its
      // path per run, so a bond's path must not depend on the thread count).
      std::set<std::tuple<Index, Index, Index, Index, bool>> runs;
      for (const BondRun& run : part.runs)
        if (run.affine) runs.insert({run.first, run.count, run.i0, run.j0, run.affine});
      if (threads == 1)
        one_part_runs = runs;
      else
        for (const auto& run : runs) EXPECT_TRUE(one_part_runs.count(run)) << "run at bond " << std::get<0>(run) << ", " << what;
    }
  }
}

TEST(BondPartition, EveryEndOfEveryAliveBondIsOwnedOnce) {
  const World w = random_lattice();
  ASSERT_GE(w.num_quanta(), kParallelMin);
  Adjacency adj;
  build_adjacency(w.model, w.state, adj);
  for (int threads : {1, 2, 3}) {
    BondPartition part;
    part.update(w.model, w.state.bonds, adj, threads);
    EXPECT_EQ(part.parts(), threads);
    std::vector<int> owned_i(w.num_bonds(), 0), owned_j(w.num_bonds(), 0);
    bool increasing = true;
    for (int p = 0; p < part.parts(); ++p) {
      const Index lo = part.first[p], hi = part.first[p + 1];
      for (Index k = part.offset[p]; k < part.offset[p + 1]; ++k) {
        const Index b = part.bonds[k];
        if (k > part.offset[p] && b <= part.bonds[k - 1]) increasing = false;
        owned_i[b] += w.state.bonds.i[b] >= lo && w.state.bonds.i[b] < hi;
        owned_j[b] += w.state.bonds.j[b] >= lo && w.state.bonds.j[b] < hi;
      }
    }
    EXPECT_TRUE(increasing) << threads;
    for (std::size_t b = 0; b < w.num_bonds(); ++b) {
      const int expected = w.state.bonds.alive[b] ? 1 : 0;
      ASSERT_EQ(owned_i[b], expected) << "bond " << b << ", " << threads << " threads";
      ASSERT_EQ(owned_j[b], expected) << "bond " << b << ", " << threads << " threads";
    }
  }
}

// The plain reference: every alive bond in order, its force added to one end and taken from the
// other; `scale` gets Σ |f_b| over each quanta's bonds.
std::vector<Vec3> plain_forces(const World& w, std::vector<double>& scale) {
  const Model& m = w.model;
  const State& s = w.state;
  std::vector<Vec3> ref(w.num_quanta(), Vec3::Zero());
  scale.assign(w.num_quanta(), 0.0);
  for (std::size_t b = 0; b < w.num_bonds(); ++b) {
    if (!s.bonds.alive[b]) continue;
    const Index i = s.bonds.i[b], j = s.bonds.j[b];
    const Vec3 f = s.bonds.force_on_i(m.shapes, b, s.x[j] - s.x[i], s.v[j] - s.v[i], s.bonds.rest[b]);
    ref[i] += f;
    ref[j] -= f;
    scale[i] += f.norm();
    scale[j] += f.norm();
  }
  return ref;
}

// The bond force pass's sums over a partition for `threads`, no external force.
std::vector<Vec3> force_pass(const World& w, const BondPartition& part, int threads) {
  const std::vector<Vec3> none(w.num_quanta(), Vec3::Zero());
  std::vector<Vec3> f;
  ForceArrays work;
  bond_force_sums(w.model, w.state, part, w.state.x, w.state.v, none, threads, work, f);
  return f;
}

// random_lattice's size and anchors (or, small, a body of 5 × 6 × 4, whose affine runs' ends are
// 1, 4, 5, 6 and more quanta apart) in the offset-grouped order, where most bonds form affine
// runs, with test::mix_bonds' uniform runs of each damping model and mixed ones; perturbed, and
// with every 97th bond broken if asked.
World grouped_lattice(bool broken, bool small = false) {
  World w = small ? test::lattice(5, 6, 4, 1000, 1e-3, 0.02, true)
                  : test::lattice(17, 16, 16, 1000, 1e-3, 0.02, true);
  renumber(w, locality_order(w));
  test::mix_bonds(w);
  test::perturb(w, 2e-3, 0.2);
  for (std::size_t b = 5; broken && b < w.num_bonds(); b += 97) w.state.break_bond(static_cast<Index>(b));
  return w;
}

// The force pass (bond_forces.hpp) against the plain one: each quanta's sum to round-off (the vector
// loops order a bond's arithmetic their own way), and the same bits at 1, 2 and 3 threads. In the
// builder's order with mixed laws and damping every bond takes the per-bond path; in the
// offset-grouped order most take the vector loops of affine runs.
TEST(BondPartition, ForcePassMatchesASerialPassAndGivesTheSameBitsAtAnyThreadCount) {
  const World grouped = grouped_lattice(true), small = grouped_lattice(true, true);
  const World builders = random_lattice();
  for (const World* pw : {&builders, &grouped, &small}) {
    const World& w = *pw;
    const bool is_grouped = pw != &builders;
    std::vector<double> scale;  // Σ |f_b| over each quanta's bonds
    const std::vector<Vec3> ref = plain_forces(w, scale);
    Adjacency adj;
    build_adjacency(w.model, w.state, adj);
    std::vector<Vec3> first;
    for (int threads : {1, 2, 3}) {
      BondPartition part;
      part.update(w.model, w.state.bonds, adj, threads);
      std::size_t vector_bonds = 0;
      for (const BondRun& r : part.runs)
        if (r.affine && uniform_linear(w.state.bonds, r) >= 0) vector_bonds += r.count;
      const std::vector<Vec3> f = force_pass(w, part, threads);
      if (threads == 1) {
        EXPECT_EQ(vector_bonds > w.num_bonds() / 3, is_grouped);
        // A bond's force differs from the plain one by a few ulps; a sum of them by as many of each term.
        for (std::size_t q = 0; q < f.size(); ++q) ASSERT_LE((f[q] - ref[q]).norm(), 1e-14 * scale[q]) << "quanta " << q;
        first = f;
      } else {
        EXPECT_EQ(std::memcmp(f.data(), first.data(), f.size() * sizeof(Vec3)), 0) << threads << " threads";
      }
    }
  }
}

// CG's product (conjugate_gradient.cpp: affine runs in vector loops, other runs bond by bond)
// against the assembled sparse matrix times the vector, to round-off, on the builder's order and
// the grouped one (intact, broken), with an anchored face whose unknowns are eliminated (their
// rows 0, their entries of y ignored); the same bits at 1-3 threads.
TEST(BondPartition, CgProductMatchesTheAssembledMatrixAndGivesTheSameBitsAtAnyThreadCount) {
  const World grouped = grouped_lattice(false), grouped_broken = grouped_lattice(true);
  const World small = grouped_lattice(false, true);
  const World builders = random_lattice();
  for (const World* w : std::initializer_list<const World*>{&builders, &grouped, &grouped_broken, &small}) {
    const std::size_t n = w->num_quanta();
    Rng rng{3};
    std::vector<Vec3> y(n);
    for (Vec3& v : y) v = Vec3(rng.uniform(), rng.uniform(), rng.uniform()) - Vec3::Constant(0.5);
    Adjacency adj;
    build_adjacency(w->model, w->state, adj);
    const std::vector<Vec3> f_ext(n, Vec3::Zero());
    std::vector<Vec3> first;
    for (int threads : {1, 2, 3}) {
      ImplicitSystem sys;
      Projection kin;
      begin_implicit_step(w->model, w->state, adj, f_ext, {.h = 1e-3}, false, threads, kin, sys);
      std::vector<Vec3> out;
      apply_system(w->model, w->state.bonds, sys, y, threads, out);
      if (threads == 1) {
        std::vector<Eigen::Index> dof;
        std::vector<Eigen::Triplet<double>> triplets;
        Eigen::SparseMatrix<double> A;
        Eigen::VectorXd b;
        Eigen::VectorXd yf(3 * assemble_system(w->model, w->state, sys, dof, triplets, A, b));
        for (std::size_t q = 0; q < n; ++q)
          if (dof[q] >= 0) yf.segment<3>(dof[q]) = y[q];
        const Eigen::VectorXd ref = A * yf, bound = A.cwiseAbs() * yf.cwiseAbs();
        std::size_t affine = 0;
        for (const BondRun& r : sys.part.runs) affine += r.affine ? r.count : 0;
        EXPECT_EQ(affine > w->num_bonds() / 2, w != &builders);
        for (std::size_t q = 0; q < n; ++q) {
          if (dof[q] < 0) {
            ASSERT_EQ(out[q], Vec3::Zero()) << "kinematic quanta " << q;
            continue;
          }
          // Each entry sums three products per block (the diagonal and each bond), each off by an
          // ulp or so.
          for (int c = 0; c < 3; ++c)
            ASSERT_LE(std::abs(out[q][c] - ref[dof[q] + c]), 1e-14 * bound[dof[q] + c]) << "quanta " << q;
        }
        first = out;
      } else {
        EXPECT_EQ(std::memcmp(out.data(), first.data(), n * sizeof(Vec3)), 0) << threads << " threads";
      }
    }
  }
}

// alone_lo/alone_hi: within the part's range, and no other part's runs (an affine run's whole
// lanes) join a quanta there; on a lattice, and on a chain whose long bonds reach across the
// middle part of three, which then has no quanta alone.
TEST(BondPartition, AQuantaAloneIsJoinedByNoOtherPartsRuns) {
  World chain;
  for (int q = 0; q < 6000; ++q) chain.add_quanta(Vec3(0.01 * q, 0, 0), Vec3::Zero(), 1e-3);
  for (Index q = 0; q + 1 < 6000; ++q) chain.add_bond(q, q + 1, {.law = Law::linear, .stiffness = 1000});
  for (Index q = 0; q + 2500 < 6000; ++q) chain.add_bond(q, q + 2500, {.law = Law::linear, .stiffness = 1000});
  const World grouped = grouped_lattice(true);
  bool some_alone = false, one_empty = false;
  for (const World* w : {&grouped, static_cast<const World*>(&chain)}) {
    Adjacency adj;
    build_adjacency(w->model, w->state, adj);
    for (int threads : {1, 2, 3}) {
      BondPartition part;
      part.update(w->model, w->state.bonds, adj, threads);
      std::vector<int> joined_by(w->num_quanta() + kBondRun, -1);  // a part whose runs join it, -2: two parts
      for (int p = 0; p < part.parts(); ++p)
        for (Index r = part.run_offset[p]; r < part.run_offset[p + 1]; ++r) {
          const BondRun& run = part.runs[r];
          auto join = [&](Index q) { joined_by[q] = joined_by[q] == -1 || joined_by[q] == p ? p : -2; };
          for (Index k = 0; k < (run.affine ? affine_lanes(run.count) : run.count); ++k) {
            const Index b = run.bond(k);
            join(run.affine ? run.i0 + k : w->state.bonds.i[b]);
            join(run.affine ? run.j0 + k : w->state.bonds.j[b]);
          }
        }
      for (int p = 0; p < part.parts(); ++p) {
        const std::string what = std::to_string(threads) + " threads, part " + std::to_string(p);
        ASSERT_LE(part.first[p], part.alone_lo[p]) << what;
        ASSERT_LE(part.alone_lo[p], part.alone_hi[p]) << what;
        ASSERT_LE(part.alone_hi[p], part.first[p + 1]) << what;
        for (Index q = part.alone_lo[p]; q < part.alone_hi[p]; ++q)
          ASSERT_TRUE(joined_by[q] == -1 || joined_by[q] == p) << what << ", quanta " << q;
        some_alone |= part.parts() > 1 && part.alone_hi[p] > part.alone_lo[p];
        one_empty |= part.parts() == 3 && part.alone_hi[p] == part.alone_lo[p];
      }
      if (threads == 1) {
        EXPECT_EQ(part.alone_hi[0] - part.alone_lo[0], w->num_quanta());
      }
    }
  }
  EXPECT_TRUE(some_alone);
  EXPECT_TRUE(one_empty);  // the chain's middle part
}

// BondRun::rows: a grid is a stretch of one part's affine runs of one count, each taking the
// bonds after the one before's, its ends the same number of quanta on; the runs after a grid's
// first are 1, and a run that could have continued the grid before it does. A 5 × 6 × 4 body's
// rows of four bonds are grids.
TEST(BondPartition, GridsAreAffineRunsOfOneShapeEachAfterTheOther) {
  const World small = grouped_lattice(false, true), grouped = grouped_lattice(true);
  for (const World* w : {&small, &grouped}) {
    Adjacency adj;
    build_adjacency(w->model, w->state, adj);
    for (int threads : {1, 2}) {
      BondPartition part;
      part.update(w->model, w->state.bonds, adj, threads);
      Index in_grids = 0;
      for (int p = 0; p < part.parts(); ++p) {
        const Index end = part.run_offset[p + 1];
        auto continues = [&](Index r, Index stride) {  // run r continues run r − 1's grid
          const BondRun &a = part.runs[r - 1], &b = part.runs[r];
          return a.affine && b.affine && b.count == a.count && b.first == a.first + a.count &&
                 b.i0 == a.i0 + stride && b.j0 == a.j0 + stride;
        };
        for (Index r = part.run_offset[p]; r < end;) {
          const Index rows = part.runs[r].rows;
          ASSERT_GE(rows, 1);
          ASSERT_LE(r + rows, end);
          if (rows > 1) {
            const Index stride = part.runs[r + 1].i0 - part.runs[r].i0;
            for (Index k = r + 1; k < r + rows; ++k) {
              ASSERT_TRUE(continues(k, stride)) << "run " << k;
              ASSERT_EQ(part.runs[k].rows, 1) << "run " << k;
            }
            if (r + rows < end) {
              EXPECT_FALSE(continues(r + rows, stride)) << "run " << r + rows;
            }
            in_grids += rows;
          }
          r += rows;
        }
      }
      if (w == &small) {
        EXPECT_GT(2 * in_grids, static_cast<Index>(part.runs.size()));
      }
    }
  }
}

TEST(BondPartition, RebuildsWhenTheTopologyChanges) {
  World w = random_lattice();
  Adjacency adj;
  build_adjacency(w.model, w.state, adj);
  BondPartition part;
  part.update(w.model, w.state.bonds, adj, 2);
  const std::size_t before = part.bonds.size();
  std::size_t b = 0;
  while (!w.state.bonds.alive[b]) ++b;
  w.state.break_bond(static_cast<Index>(b));
  build_adjacency(w.model, w.state, adj);
  part.update(w.model, w.state.bonds, adj, 2);
  EXPECT_LT(part.bonds.size(), before);
  for (Index k : part.bonds) EXPECT_NE(k, static_cast<Index>(b));
}

// BondRun::kind is uniform_linear's answer for each affine run (−1 for the others), and is
// formed again when a bond's law changes with the topology version bumped (world.hpp).
TEST(BondPartition, RunKindsAreEachRunsLawsAndFollowALawChange) {
  World w = grouped_lattice(false);
  Adjacency adj;
  build_adjacency(w.model, w.state, adj);
  BondPartition part;
  part.update(w.model, w.state.bonds, adj, 2);
  const BondRun* linear = nullptr;
  std::set<int> kinds;
  for (const BondRun& run : part.runs) {
    EXPECT_EQ(run.kind, run.affine ? uniform_linear(w.state.bonds, run) : -1);
    kinds.insert(run.kind);
    if (!linear && run.kind == 0) linear = &run;
  }
  EXPECT_EQ(kinds, (std::set<int>{-1, 0, 1}));
  ASSERT_NE(linear, nullptr);
  const Index first = linear->first, b = first + linear->count / 2;
  w.state.edit_bonds().law[b] = Law::inverse;
  build_adjacency(w.model, w.state, adj);
  part.update(w.model, w.state.bonds, adj, 2);
  for (const BondRun& run : part.runs)
    if (run.affine && run.first <= b && b < run.first + run.count) {
      EXPECT_EQ(run.kind, -1) << "run from bond " << run.first;
    }
}

// The kernels' per-quanta arrays start on cache lines (affine_run_terms.hpp: an 8-wide access at a
// multiple of 8 quanta then takes one line), their buffer keeps its size when asked for fewer
// arrays, and the arrays fit in it; so do velocity Verlet's carried rows, which its force pass
// updates.
TEST(SoaArrays, StartOnCacheLinesAndFitTheirBuffer) {
  LineVector<double> buffer;
  for (std::size_t n : {std::size_t{1}, std::size_t{1000}, std::size_t{700}}) {
    const std::size_t count = 5;
    SoaArrays soa(buffer, n, count);
    for (std::size_t k = 0; k < count; ++k) {
      const double* a = soa.next();
      EXPECT_EQ(reinterpret_cast<std::uintptr_t>(a) % 64, 0u) << n << " " << k;
      EXPECT_LE(a + soa.stride(), buffer.data() + buffer.size());
    }
  }
  EXPECT_EQ(buffer.size(), 5 * soa_stride(1000));
  for (std::size_t n : {1, 3, 1000, 100000}) {
    VerletForces c;
    c.resize(n);
    EXPECT_EQ(c.stride(), soa_stride(n));
    for (std::size_t k = 0; k < 3; ++k) {
      EXPECT_EQ(reinterpret_cast<std::uintptr_t>(c.f.data() + k * c.stride()) % 64, 0u) << n;
      EXPECT_EQ(reinterpret_cast<std::uintptr_t>(c.x.data() + k * c.stride()) % 64, 0u) << n;
    }
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(c.v.data()) % 64, 0u) << n;
  }
}
}  // namespace
}  // namespace qbond
