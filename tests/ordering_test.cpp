// Renumbering for locality (ordering.hpp): the order it makes, and that a renumbered world is
// the same physical system, its user ids kept.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <tuple>

#include "integrators/bond_partition.hpp"
#include "qbond/model/ordering.hpp"
#include "qbond/builders/packing.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

Renumbering shuffled(const World& w, std::uint64_t seed) {
  Renumbering r;
  r.quanta.resize(w.num_quanta());
  r.bonds.resize(w.num_bonds());
  std::iota(r.quanta.begin(), r.quanta.end(), Index{0});
  std::iota(r.bonds.begin(), r.bonds.end(), Index{0});
  std::mt19937_64 rng(seed);
  std::shuffle(r.quanta.begin(), r.quanta.end(), rng);
  std::shuffle(r.bonds.begin(), r.bonds.end(), rng);
  return r;
}

bool is_identity(const std::vector<Index>& p) {
  for (std::size_t k = 0; k < p.size(); ++k)
    if (p[k] != k) return false;
  return true;
}

// Rows of 3 quanta are too short for affine runs (kMinAffine): the bonds go in (first, second)
// order.
TEST(Ordering, ABuildersLatticeKeepsItsQuantaOrderAndSortingTwiceChangesNothing) {
  World w = test::lattice(3, 3, 3, 1000, 1e-3, 0.01, true);
  const Renumbering r = locality_order(w);
  EXPECT_TRUE(is_identity(r.quanta));
  renumber(w, r);
  for (std::size_t b = 1; b < w.num_bonds(); ++b) {
    const auto key = [&](std::size_t c) { return std::pair(w.state.bonds.i[c], w.state.bonds.j[c]); };
    EXPECT_LT(key(b - 1), key(b));
  }
  const Renumbering again = locality_order(w);
  EXPECT_TRUE(is_identity(again.quanta));
  EXPECT_TRUE(is_identity(again.bonds));
}

// How many alive bonds lie in affine segments (bond_partition.hpp).
std::size_t affine_bonds(const World& w) {
  std::size_t count = 0;
  for_each_affine_segment(w.state.bonds.i.data(), w.state.bonds.j.data(), static_cast<Index>(w.num_bonds()), kMinAffine,
                          [&](Index b) { return w.state.bonds.alive[b] != 0; }, [&](Index, Index n) { count += n; });
  return count;
}

// A lattice with rows longer than kMinAffine gets its bonds grouped by block of first ends, then
// offset, then first end, which puts them in affine runs (the frozen step's vector path); sorting
// again changes nothing. A Poisson packing has no such runs and keeps the (first, second) order.
TEST(Ordering, ALatticesBondsFormAffineRunsAPackingsDoNot) {
  World w = test::lattice(12, 9, 5, 1000, 1e-3, 0.01, true);
  EXPECT_EQ(affine_bonds(w), 0u);  // the builder makes each quanta's bonds in turn
  renumber(w, shuffled(w, 5));
  renumber(w, locality_order(w));
  const State& s = w.state;
  // Rows of 12 quanta: a row's run along x has 11 bonds, the diagonals' 10 or 11, and the runs
  // along y and z go on over whole planes, cut at the blocks of first ends: 10 whole rows, 120
  // quanta.
  EXPECT_GT(affine_bonds(w), 9 * w.num_bonds() / 10);
  auto key = [&](std::size_t b) {
    const Index i = s.bonds.i[b], j = s.bonds.j[b];
    return std::tuple(i / 120, std::int64_t{j} - i, i);
  };
  for (std::size_t b = 1; b < w.num_bonds(); ++b) EXPECT_LT(key(b - 1), key(b)) << b;
  const Renumbering again = locality_order(w);
  EXPECT_TRUE(is_identity(again.quanta));
  EXPECT_TRUE(is_identity(again.bonds));

  World p;
  PointPacking packing;
  packing.size = Vec3(0.2, 0.1, 0.1);
  add_point_packing(p, packing);
  ASSERT_GT(p.num_bonds(), 1000u);
  renumber(p, locality_order(p));
  EXPECT_LT(affine_bonds(p), p.num_bonds() / 10);
  for (std::size_t b = 1; b < p.num_bonds(); ++b)
    EXPECT_LT(std::pair(p.state.bonds.i[b - 1], p.state.bonds.j[b - 1]),
              std::pair(p.state.bonds.i[b], p.state.bonds.j[b]));
}

// The lengths of the affine segments (bond_partition.hpp) of bonds joining quanta one apart.
std::vector<Index> segments_along_x(const World& w) {
  std::vector<Index> lengths;
  for_each_affine_segment(
      w.state.bonds.i.data(), w.state.bonds.j.data(), static_cast<Index>(w.num_bonds()), kMinAffine,
      [](Index) { return true; },
      [&](Index b, Index n) {
        if (w.state.bonds.j[b] - w.state.bonds.i[b] == 1) lengths.push_back(n);
      });
  return lengths;
}

// The blocks of first ends hold whole rows: a row's bonds along x are one affine segment, not
// cut where a block of 128 would end (rows of 40: three rows a block). A row longer than a block
// is cut into equal pieces (200: two of 100).
TEST(Ordering, TheBlocksOfFirstEndsHoldWholeRows) {
  World w = test::lattice(40, 5, 3, 1000, 1e-3, 0.01, true);
  renumber(w, locality_order(w));
  const std::vector<Index> rows = segments_along_x(w);
  EXPECT_EQ(rows.size(), 5u * 3u);
  for (Index n : rows) EXPECT_EQ(n, 39);

  World l = test::lattice(200, 2, 2, 1000, 1e-3, 0.01, true);
  renumber(l, locality_order(l));
  const std::vector<Index> pieces = segments_along_x(l);
  ASSERT_EQ(pieces.size(), 2u * 2u * 2u);
  for (std::size_t k = 0; k < pieces.size(); k += 2) {
    EXPECT_EQ(pieces[k], 100);     // first ends 0..99 of the row
    EXPECT_EQ(pieces[k + 1], 99);  // 100..198
  }
}

// A lattice built and then rotated (as a scene's "rotation" places a body) is numbered row by
// row in its own axes; binning its quanta in the world's axes would scramble the rows and leave
// its bonds no affine runs. It keeps its numbering, its bonds in affine runs as an unrotated
// one's, and sorting again changes nothing.
TEST(Ordering, ARotatedLatticeKeepsItsRows) {
  World straight = test::lattice(12, 9, 5, 1000, 1e-3, 0.01, true);
  World w = straight;
  std::vector<Index> all(w.num_quanta());
  std::iota(all.begin(), all.end(), Index{0});
  place_body(w, all, Placement{.origin = Vec3(0.1, 0, 0.2), .axis = Vec3(1, 1, 0).normalized(), .angle = 0.4});
  const Renumbering r = locality_order(w);
  EXPECT_TRUE(is_identity(r.quanta));
  renumber(w, r);
  renumber(straight, locality_order(straight));
  EXPECT_EQ(affine_bonds(w), affine_bonds(straight));
  EXPECT_GT(affine_bonds(w), 9 * w.num_bonds() / 10);
  const Renumbering again = locality_order(w);
  EXPECT_TRUE(is_identity(again.quanta));
  EXPECT_TRUE(is_identity(again.bonds));
  // The world's bins alone would have lost the runs.
  World binned = w;
  renumber(binned, shuffled(binned, 3));
  renumber(binned, locality_order(binned));
  EXPECT_LT(affine_bonds(binned), w.num_bonds() / 2);
}

TEST(Ordering, AShuffledLatticeGetsItsRowsBack) {
  const World built = test::lattice(7, 5, 4, 1000, 1e-3, 0.01, true);
  World w = built;
  renumber(w, shuffled(w, 7));
  renumber(w, locality_order(w));
  // Quanta come back in the builder's order (x fastest), with their user ids.
  ASSERT_EQ(w.num_quanta(), built.num_quanta());
  for (std::size_t i = 0; i < w.num_quanta(); ++i) {
    EXPECT_EQ(w.state.x[i], built.state.x[i]);
    EXPECT_EQ(w.model.quanta_id[i], i);
  }
}

TEST(Ordering, ARenumberedWorldIsTheSameSystem) {
  World w = test::lattice(5, 4, 3, 1000, 1e-3, 0.01, true, Vec3(0, 0, -9.81));
  w.add_load({3, 17}, Vec3(0.1, 0, 0));
  w.break_bond(5);
  const World original = w;
  const Renumbering r = shuffled(w, 3);
  renumber(w, r);
  const Model &m = w.model, &m0 = original.model;
  const Bonds &bonds = w.state.bonds, &bonds0 = original.state.bonds;
  for (std::size_t i = 0; i < w.num_quanta(); ++i) {
    const Index k = r.quanta[i];
    EXPECT_EQ(w.state.x[k], original.state.x[i]);
    EXPECT_EQ(w.state.v[k], original.state.v[i]);
    EXPECT_EQ(m.mass[k], m0.mass[i]);
    EXPECT_EQ(m.inv_mass[k], m0.inv_mass[i]);
    EXPECT_EQ(m.quanta_id[k], i);
  }
  for (std::size_t b = 0; b < w.num_bonds(); ++b) {
    const Index k = r.bonds[b];
    EXPECT_EQ(bonds.i[k], r.quanta[bonds0.i[b]]);
    EXPECT_EQ(bonds.j[k], r.quanta[bonds0.j[b]]);
    EXPECT_EQ(bonds.strength[k], bonds0.strength[b]);
    EXPECT_EQ(bonds.rest[k], bonds0.rest[b]);
    EXPECT_EQ(bonds.alive[k], bonds0.alive[b]);
    EXPECT_EQ(bonds.id[k], b);
  }
  for (std::size_t a = 0; a < m.motions.size(); ++a)
    for (std::size_t q = 0; q < m.motions[a].quanta.size(); ++q)
      EXPECT_EQ(m.motions[a].quanta[q], r.quanta[m0.motions[a].quanta[q]]);
  EXPECT_EQ(m.loads[0].quanta, (std::vector<Index>{r.quanta[3], r.quanta[17]}));
  EXPECT_GT(w.state.topology_version(), original.state.topology_version());
}

// Each quanta's motion after some steps, whatever the numbering: for the integrators whose step
// does not depend on an order (explicit, the frozen hybrid, CG, which is invariant under a
// symmetric permutation of its system and preconditioner) only the order of the bond sums
// changes, so the two runs agree to round-off. (A Gauss–Seidel sweep visits quanta in colour
// order, and the greedy colouring follows the numbering: its iterate is a different, equally
// valid, approximation.)
TEST(Ordering, StepsAgreeToRoundOffWhateverTheNumbering) {
  IntegratorConfig verlet, frozen, coupled;
  verlet.type = IntegratorType::velocity_verlet;
  frozen.type = IntegratorType::hybrid_implicit;
  frozen.neighbours = NeighbourModel::frozen;
  coupled.tolerance = 1e-12;
  for (const IntegratorConfig& cfg : {verlet, frozen, coupled}) {
    // Rows of 10 quanta: sorted, most bonds form affine runs (the frozen step's vector path).
    World a = test::lattice(10, 5, 4, 1000, 1e-3, 0.01, true, Vec3(0, 0, -9.81));
    World b = a;
    renumber(b, shuffled(b, 11));
    World c = b;
    renumber(c, locality_order(c));
    ASSERT_GT(affine_bonds(c), c.num_bonds() / 2);
    Simulation sa(std::move(a), cfg, 1e-4), sb(std::move(b), cfg, 1e-4), sc(std::move(c), cfg, 1e-4);
    for (int k = 0; k < 50; ++k) {
      sa.step();
      sb.step();
      sc.step();
    }
    double scale = 0;
    for (const Vec3& x : sa.world().state.x) scale = std::max(scale, x.norm());
    for (const Simulation* s : {&sb, &sc}) {
      const std::vector<Index> at = quanta_by_id(s->world().model);
      double worst = 0;
      for (std::size_t i = 0; i < sa.world().num_quanta(); ++i)
        worst = std::max(worst, (s->world().state.x[at[i]] - sa.world().state.x[i]).norm());
      // 50 steps, each adding a few ulps (2.2e-16) of the motion's scale: ~1e-14 at the most.
      EXPECT_LE(worst, 1e-13 * scale) << to_string(cfg.type) << (s == &sc ? ", sorted" : ", shuffled");
    }
  }
}

}  // namespace
}  // namespace qbond
