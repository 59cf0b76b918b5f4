// The pieces a run over ranks is made of, without MPI: the bisection of space into boxes, each
// rank's piece of the world and its halo lists (src/distributed/). The runs themselves over 2 and 3
// ranks are the tests labelled mpi (tests/mpi/).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "distributed/local_world.hpp"
#include "distributed/partition.hpp"
#include "integrators/bond_forces.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/distributed/distributed.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

using distributed::bisect;
using distributed::parts_of;

std::vector<std::size_t> counts(const std::vector<int>& parts, int n) {
  std::vector<std::size_t> c(static_cast<std::size_t>(n), 0);
  for (int p : parts) ++c[static_cast<std::size_t>(p)];
  return c;
}

// The 10³ lattice in 3: a third along x is 333, and the cut between lattice planes nearest it
// leaves 300; the other 700 are cut along their longest side, y, into two halves of 5 planes.
TEST(Bisection, CutsALatticeBetweenItsPlanesInProportionToTheParts) {
  const World w = canonical_lattice(10).world;
  const distributed::Bisection b = bisect(w.state.x, 3);
  EXPECT_EQ(counts(parts_of(b, w.state.x), 3), (std::vector<std::size_t>{300, 350, 350}));
  EXPECT_EQ(counts(parts_of(bisect(w.state.x, 2), w.state.x), 2), (std::vector<std::size_t>{500, 500}));
  // Every cut lies halfway between two planes (spacing 0.01 m): no quanta within 5 mm of one.
  for (const auto& node : b.nodes) {
    if (node.part >= 0) continue;
    for (const Vec3& x : w.state.x) EXPECT_GE(std::abs(x[node.axis] - node.cut), 0.005 - 1e-12);
  }
}

TEST(Bisection, IsTheSameForTheSamePointsAndKeepsPointsThatCannotBeSplit) {
  const World w = canonical_lattice(6).world;
  std::vector<Vec3> x = w.state.x;
  const std::vector<int> once = parts_of(bisect(x, 5), x);
  EXPECT_EQ(once, parts_of(bisect(x, 5), x));
  const std::vector<std::size_t> c = counts(once, 5);
  EXPECT_EQ(std::count(c.begin(), c.end(), 0u), 0);
  // All at one place: nothing can be cut, every point goes to one part, the others are empty.
  const std::vector<Vec3> same(7, Vec3(1, 2, 3));
  const std::vector<std::size_t> one = counts(parts_of(bisect(same, 3), same), 3);
  EXPECT_EQ(*std::max_element(one.begin(), one.end()), 7u);
}

// A checkpoint keeps the boxes as JSON: read back, every cut (a cut that sends every point right
// included) and so every point's part are the same bits; text that is not a bisection is refused.
TEST(Bisection, TravelsThroughJsonToTheBitAndRefusesWhatIsNotOne) {
  const World w = canonical_lattice(6).world;
  std::vector<Vec3> x = w.state.x;
  x.resize(20);
  for (int parts : {1, 2, 3, 5}) {
    const distributed::Bisection b = bisect(x, parts);
    const distributed::Bisection back = distributed::bisection_from_json(distributed::bisection_json(b));
    ASSERT_EQ(back.parts, b.parts);
    ASSERT_EQ(back.nodes.size(), b.nodes.size());
    for (std::size_t k = 0; k < b.nodes.size(); ++k) {
      EXPECT_EQ(back.nodes[k].part, b.nodes[k].part);
      EXPECT_EQ(back.nodes[k].axis, b.nodes[k].axis);
      EXPECT_EQ(back.nodes[k].cut, b.nodes[k].cut);  // bit for bit, +inf included
      EXPECT_EQ(back.nodes[k].left, b.nodes[k].left);
      EXPECT_EQ(back.nodes[k].right, b.nodes[k].right);
    }
    EXPECT_EQ(parts_of(back, x), parts_of(b, x));
  }
  const std::vector<Vec3> same(4, Vec3(1, 2, 3));
  EXPECT_FALSE(std::isfinite(bisect(same, 2).nodes[0].cut));
  EXPECT_EQ(distributed::bisection_from_json(distributed::bisection_json(bisect(same, 2))).nodes[0].cut, HUGE_VAL);
  for (const char* bad : {"", "[]", R"({"parts": 2})", R"({"parts": 2, "nodes": []})",
                          R"({"parts": 2, "nodes": [[-1, 0, 0.5, 1, 2], [0, 0, 0, -1, -1], [0, 0, 0, -1, -1]]})",
                          R"({"parts": 2, "nodes": [[-1, 0, 0.5, 0, 2], [0, 0, 0, -1, -1], [1, 0, 0, -1, -1]]})",
                          R"({"parts": 2, "nodes": [[-1, 3, 0.5, 1, 2], [0, 0, 0, -1, -1], [1, 0, 0, -1, -1]]})",
                          R"({"parts": 1, "nodes": [[0, 0, "x", -1, -1]]})",
                          R"({"parts": 1, "nodes": [[0, 0, 0, -1, -1]], "strays": [[3, 1]]})",
                          R"({"parts": 1, "nodes": [[0, 0, 0, -1, -1]], "strays": [[-3, 0]]})",
                          R"({"parts": 1, "nodes": [[0, 0, 0, -1, -1]], "owners": []})"})
    EXPECT_THROW(distributed::bisection_from_json(bad), std::invalid_argument) << bad;
  // The quanta owned outside their box travel with it.
  const distributed::Strays strays{{4, 0}, {11, 2}};
  distributed::Strays back;
  (void)distributed::bisection_from_json(distributed::bisection_json(bisect(x, 3), strays), &back);
  EXPECT_EQ(back, strays);
}

// A part's box holds exactly the points the bisection gives that part: [lo, hi) on each axis.
TEST(Bisection, APartsBoxHoldsItsPoints) {
  const World w = canonical_lattice(6).world;
  const distributed::Bisection b = bisect(w.state.x, 5);
  const std::vector<int> part = parts_of(b, w.state.x);
  for (int p = 0; p < 5; ++p) {
    Vec3 lo, hi;
    b.box(p, lo, hi);
    for (std::size_t q = 0; q < part.size(); ++q) {
      const Vec3& x = w.state.x[q];
      const bool inside = (x.array() >= lo.array()).all() && (x.array() < hi.array()).all();
      EXPECT_EQ(inside, part[q] == p) << "part " << p << ", point " << q;
    }
  }
}

// A world with anchors, a prescribed motion, a load, two bodies and a broken bond, cut into `ranks`.
World test_world() {
  Scene s = parse_scene(R"({
    "name": "pieces", "timestep": 1e-4, "steps": 1, "gravity": [0, 0, -9.81],
    "materials": {"m": {"law": "linear", "stiffness": 2000, "damping": 0.05}},
    "bodies": [
      {"name": "a", "type": "lattice", "cell": "cubic", "neighbors": "face_diagonal", "size": [7, 4, 3],
       "spacing": 0.01, "quanta_mass": 0.001, "material": "m", "velocity": [1, 0, 0]},
      {"name": "b", "type": "lattice", "cell": "cubic", "size": [3, 3, 3], "spacing": 0.01,
       "quanta_mass": 0.002, "material": "m", "origin": [0.02, 0.06, 0]}],
    "anchors": [{"select": {"box": [[-0.001, -1, -1], [0.001, 1, 1]]}},
                {"select": {"body": "b"}, "motion": {"translate": {"velocity": [0, 1, 0]}}}],
    "loads": [{"select": {"box": [[0.005, -1, -1], [1, 0.035, 1]]}, "force": [0.3, -0.2, 0.1]}]
  })");
  World w = std::move(s.world);
  w.break_bond(3);
  test::perturb(w, 1e-3, 0.1);
  return w;
}

class Pieces : public ::testing::TestWithParam<int> {};

// Every quanta owned once, every alive bond accounted for once, the halo lists each other's
// mirror, each owned quanta's bond force exactly the whole world's (its bonds all in its piece,
// summed in the same order), and each local quanta of a load's selection pushed by the whole
// load's share.
TEST_P(Pieces, HoldEveryQuantaAndBondOnceWithTheWholeWorldsForces) {
  const int ranks = GetParam();
  const World whole = test_world();
  const std::vector<int> owner = parts_of(bisect(whole.state.x, ranks), whole.state.x);
  Adjacency adj;
  build_adjacency(whole.model, whole.state, adj);
  BondPartition part;
  part.update(whole.model, whole.state.bonds, adj, 1);
  ForceArrays work;
  const ForceRows f = bond_force_rows(whole.model, whole.state, part, whole.state.x.data(), whole.state.v.data(), 1, work);
  std::vector<int> owned_by(whole.num_quanta(), -1);
  std::size_t bonds = 0, loaded = 0;
  ASSERT_EQ(whole.model.loads.size(), 1u);
  const Load& load = whole.model.loads[0];
  std::map<std::pair<int, int>, std::vector<Index>> sends, recvs;  // (from, to): whole indices
  for (int r = 0; r < ranks; ++r) {
    const distributed::Piece p = distributed::make_piece(whole, owner, r);
    const World& w = p.world;
    EXPECT_EQ(p.whole_alive_bonds, whole.num_alive_bonds());
    EXPECT_TRUE(std::is_sorted(p.global.begin(), p.global.end()));
    bonds += p.owned_bonds.size();
    for (Index q : p.owned_quanta) {
      EXPECT_EQ(owned_by[p.global[q]], -1) << "quanta " << p.global[q] << " owned twice";
      owned_by[p.global[q]] = r;
    }
    // Each local bond names its whole bond: the same ends and id, in the whole world's order.
    ASSERT_EQ(p.whole_bond.size(), w.state.bonds.size());
    EXPECT_TRUE(std::is_sorted(p.whole_bond.begin(), p.whole_bond.end()));
    for (std::size_t b = 0; b < p.whole_bond.size(); ++b) {
      const Index wb = p.whole_bond[b];
      EXPECT_EQ(p.global[w.state.bonds.i[b]], whole.state.bonds.i[wb]);
      EXPECT_EQ(p.global[w.state.bonds.j[b]], whole.state.bonds.j[wb]);
      EXPECT_EQ(w.state.bonds.id[b], whole.state.bonds.id[wb]);
    }
    for (std::size_t q = 0; q < p.global.size(); ++q) {
      EXPECT_EQ(w.state.x[q], whole.state.x[p.global[q]]);
      EXPECT_EQ(w.model.inv_mass[q], whole.model.inv_mass[p.global[q]]);
    }
    std::size_t prescribed = 0;
    for (const Motion& m : w.model.motions) {
      for (std::size_t k = 0; k < m.quanta.size(); ++k) EXPECT_EQ(m.x0[k], w.state.x[m.quanta[k]]);
      prescribed += m.quanta.size();
    }
    EXPECT_EQ(prescribed, static_cast<std::size_t>(std::count(w.model.inv_mass.begin(), w.model.inv_mass.end(), 0.0)));
    ASSERT_EQ(w.model.loads.size(), 1u);
    const Load& mine = w.model.loads[0];
    EXPECT_EQ(mine.share(), load.share());
    std::vector<Index> selected;
    for (Index q : load.quanta)
      if (std::binary_search(p.global.begin(), p.global.end(), q)) selected.push_back(q);
    std::vector<Index> held;
    for (Index q : mine.quanta) {
      held.push_back(p.global[q]);
      loaded += p.owned[q];
    }
    EXPECT_EQ(held, selected) << "the local quanta of the selection, in its order";
    Adjacency padj;
    build_adjacency(w.model, w.state, padj);
    BondPartition ppart;
    ppart.update(w.model, w.state.bonds, padj, 1);
    ForceArrays pwork;
    const ForceRows pf = bond_force_rows(w.model, w.state, ppart, w.state.x.data(), w.state.v.data(), 1, pwork);
    for (Index q : p.owned_quanta)
      for (int c = 0; c < 3; ++c) EXPECT_EQ(pf.f[c][q], f.f[c][p.global[q]]) << "quanta " << p.global[q];
    const distributed::HaloPlan plan = distributed::halo_plan(whole, owner, r, p);
    std::set<Index> ghosts;
    for (std::size_t k = 0; k < plan.peers.size(); ++k) {
      for (Index q : plan.send[k]) {
        EXPECT_TRUE(p.owned[q]);
        sends[{r, plan.peers[k]}].push_back(p.global[q]);
      }
      for (Index q : plan.recv[k]) {
        EXPECT_FALSE(p.owned[q]);
        EXPECT_EQ(owner[p.global[q]], plan.peers[k]);
        ghosts.insert(q);
        recvs[{plan.peers[k], r}].push_back(p.global[q]);
      }
    }
    EXPECT_EQ(ghosts.size(), p.global.size() - p.owned_quanta.size()) << "every ghost is received";
  }
  EXPECT_EQ(std::count(owned_by.begin(), owned_by.end(), -1), 0);
  EXPECT_EQ(bonds, whole.num_alive_bonds());
  EXPECT_EQ(loaded, load.quanta.size()) << "each loaded quanta owned once";
  EXPECT_EQ(sends, recvs);
  if (ranks > 1) {
    EXPECT_FALSE(sends.empty());
  }
}

INSTANTIATE_TEST_SUITE_P(Ranks, Pieces, ::testing::Values(1, 2, 3, 4));

// With quanta contact a piece holds, besides its bonds' ghosts, every quanta within the reach of
// an owned one (with two layers, of a local one), found here by testing every pair; every bond
// whose ends are both local (a touching pair of local quanta is skipped when bonded); and the
// halo lists mirror each other.
TEST_P(Pieces, ContactHalosHoldEveryQuantaWithinReach) {
  const int ranks = GetParam();
  const World whole = test_world();
  const std::vector<int> owner = parts_of(bisect(whole.state.x, ranks), whole.state.x);
  const std::size_t n = whole.num_quanta();
  const Bonds& wb = whole.state.bonds;
  constexpr double kReach = 0.015;
  for (int layers : {1, 2}) {
    distributed::ContactHalo halo{.near = {}, .layers = layers};
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = i + 1; j < n; ++j)
        if ((whole.state.x[j] - whole.state.x[i]).norm() < kReach)
          halo.near.emplace_back(static_cast<Index>(i), static_cast<Index>(j));
    std::map<std::pair<int, int>, std::vector<Index>> sends, recvs;
    for (int r = 0; r < ranks; ++r) {
      // The local quanta by their definition: owned, bonded to an owned one, or within reach of
      // an owned one (of one of those, with two layers).
      std::vector<std::uint8_t> want(n, 0), first(n, 0);
      for (std::size_t q = 0; q < n; ++q) {
        if (owner[q] != r) continue;
        want[q] = 1;
        for (std::size_t o = 0; o < n; ++o)
          if ((whole.state.x[o] - whole.state.x[q]).norm() < kReach) want[o] = 1;
      }
      for (std::size_t b = 0; b < wb.size(); ++b)
        if (wb.alive[b] && (owner[wb.i[b]] == r || owner[wb.j[b]] == r)) want[wb.i[b]] = want[wb.j[b]] = 1;
      if (layers == 2) {
        first = want;
        for (std::size_t q = 0; q < n; ++q)
          for (std::size_t o = 0; o < n && first[q]; ++o)
            if ((whole.state.x[o] - whole.state.x[q]).norm() < kReach) want[o] = 1;
      }
      const distributed::Piece p = distributed::make_piece(whole, owner, r, halo);
      std::vector<Index> expected;
      for (std::size_t q = 0; q < n; ++q)
        if (want[q]) expected.push_back(static_cast<Index>(q));
      EXPECT_EQ(p.global, expected) << layers << " layers, rank " << r;
      std::size_t between = 0;
      for (std::size_t b = 0; b < wb.size(); ++b) between += wb.alive[b] && want[wb.i[b]] && want[wb.j[b]];
      EXPECT_EQ(p.world.state.bonds.size(), between) << "the bonds between local quanta";
      const distributed::HaloPlan plan = distributed::halo_plan(whole, owner, r, p, halo);
      std::size_t received = 0;
      for (std::size_t k = 0; k < plan.peers.size(); ++k) {
        for (Index q : plan.send[k]) sends[{r, plan.peers[k]}].push_back(p.global[q]);
        for (Index q : plan.recv[k]) recvs[{plan.peers[k], r}].push_back(p.global[q]);
        received += plan.recv[k].size();
      }
      EXPECT_EQ(received, p.global.size() - p.owned_quanta.size()) << "every ghost is received";
    }
    EXPECT_EQ(sends, recvs);
  }
}

TEST(Ranks, AProgramStartedAloneIsOneRank) {
  EXPECT_EQ(mpi_ranks(), 1);
  EXPECT_EQ(mpi_rank(), 0);
}

}  // namespace
}  // namespace qbond
