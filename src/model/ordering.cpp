#include "qbond/model/ordering.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <numeric>
#include <tuple>

#include "integrators/bond_partition.hpp"

namespace qbond {

namespace {

// Indices 0..n-1 sorted by `less` (ties by index).
template <class Less>
std::vector<Index> sorted_by(std::size_t n, Less&& less) {
  std::vector<Index> order(n);
  std::iota(order.begin(), order.end(), Index{0});
  std::sort(order.begin(), order.end(), [&](Index a, Index b) { return less(a, b) || (!less(b, a) && a < b); });
  return order;
}

// The new index of each old one, for indices in their new order.
std::vector<Index> rank_of(const std::vector<Index>& order) {
  std::vector<Index> rank(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) rank[order[k]] = static_cast<Index>(k);
  return rank;
}

// Sorts indices 0..n-1 by key (ties by index) and returns the new index of each old one.
std::vector<Index> rank_by(const std::vector<std::uint64_t>& key) {
  return rank_of(sorted_by(key.size(), [&](Index a, Index b) { return key[a] < key[b]; }));
}

// The block of first ends each quanta belongs to (offset_grouped): whole rows — runs of quanta
// joined one to the next by bonds of index offset 1, a lattice's x rows — packed up to
// kOffsetBlock quanta a block, a longer row cut into equal pieces of at most that many. Blocks
// cut at fixed multiples cut a lattice's rows too (40-quanta rows in blocks of 128: one row in
// four split in two), and each piece of a row is one more affine run of each offset along x,
// whose set-up every bond kernel pays again.
constexpr Index kOffsetBlock = 128;
std::vector<Index> offset_blocks(const std::vector<Index>& i, const std::vector<Index>& j, std::size_t n) {
  std::vector<std::uint8_t> joined(n, 0);  // joined[q]: a bond joins q − 1 and q
  for (std::size_t b = 0; b < i.size(); ++b)
    if (std::max(i[b], j[b]) - std::min(i[b], j[b]) == 1) joined[std::max(i[b], j[b])] = 1;
  std::vector<Index> block(n);
  Index id = 0, size = 0;  // the current block and how many quanta it has
  for (std::size_t row = 0; row < n;) {
    std::size_t end = row + 1;
    while (end < n && joined[end]) ++end;
    const std::size_t length = end - row;
    if (size > 0 && size + length > kOffsetBlock) {
      ++id;
      size = 0;
    }
    const std::size_t pieces = (length + kOffsetBlock - 1) / kOffsetBlock;
    for (std::size_t k = 0; k < length; ++k) block[row + k] = id + static_cast<Index>(k * pieces / length);
    if (pieces > 1) {
      id += static_cast<Index>(pieces);
    } else {
      size += static_cast<Index>(length);
    }
    row = end;
  }
  return block;
}

// The bonds in the order that makes affine segments (bond_partition.hpp) of a lattice: by block
// of first ends (offset_blocks), then by the offset j − i, then by i (i, j: the ends' new
// numbers). Within a block, the bonds of one offset whose first ends are consecutive quanta (a
// lattice row) are then consecutive bonds with both ends advancing by one. A block's first ends
// and their rows stay in the first-level cache over its offsets.
std::vector<Index> offset_grouped(const std::vector<Index>& i, const std::vector<Index>& j, std::size_t n) {
  const std::vector<Index> block = offset_blocks(i, j, n);
  auto key = [&](Index b) { return std::tuple(block[i[b]], static_cast<std::int64_t>(j[b]) - i[b], i[b]); };
  return sorted_by(i.size(), [&](Index a, Index b) { return key(a) < key(b); });
}

// How many of the bonds, taken in `order`, lie in affine segments.
std::size_t affine_bonds(const std::vector<Index>& order, const std::vector<Index>& i, const std::vector<Index>& j) {
  std::vector<Index> oi(order.size()), oj(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    oi[k] = i[order[k]];
    oj[k] = j[order[k]];
  }
  std::size_t count = 0;
  for_each_affine_segment(oi.data(), oj.data(), static_cast<Index>(order.size()), kMinAffine,
                          [](Index) { return true; },
                          [&](Index, Index n) { count += n; });
  return count;
}

// at[p[k]] = k for a permutation p.
std::vector<Index> inverse(const std::vector<Index>& p) {
  std::vector<Index> at(p.size());
  for (std::size_t k = 0; k < p.size(); ++k) at[p[k]] = static_cast<Index>(k);
  return at;
}

// The spacing of the quanta: the median over quanta of their shortest bond's length (the
// nearest-neighbour distance, a lattice's spacing); without bonds, the mean spacing of n points
// in the bounding box.
double spacing(const Model& m, const State& s, double extent) {
  const std::size_t n = m.num_quanta();
  std::vector<double> shortest(n, std::numeric_limits<double>::infinity());
  const Bonds& bonds = s.bonds;
  for (std::size_t b = 0; b < bonds.size(); ++b) {
    if (!bonds.alive[b]) continue;
    const Index i = bonds.i[b], j = bonds.j[b];
    const double r = (s.x[i] - s.x[j]).norm();
    shortest[i] = std::min(shortest[i], r);
    shortest[j] = std::min(shortest[j], r);
  }
  std::erase_if(shortest, [](double r) { return !(r > 0 && r < std::numeric_limits<double>::infinity()); });
  if (shortest.empty()) return extent / std::cbrt(static_cast<double>(n));
  auto mid = shortest.begin() + static_cast<std::ptrdiff_t>(shortest.size() / 2);
  std::nth_element(shortest.begin(), mid, shortest.end());
  return *mid;
}

// The scene's bonds' order for a numbering of the quanta (quanta i becomes rank[i]): grouped by
// block of first ends and offset when that puts at least half of them in affine segments, else
// by (first end, second end); and how many are in affine segments grouped.
struct BondOrder {
  std::vector<Index> rank;
  std::size_t affine;
};

BondOrder bond_order(const Bonds& bonds, const std::vector<Index>& rank, std::size_t scene_bonds) {
  std::vector<Index> bi(scene_bonds), bj(scene_bonds);
  for (std::size_t b = 0; b < scene_bonds; ++b) {
    bi[b] = rank[bonds.i[b]];
    bj[b] = rank[bonds.j[b]];
  }
  const std::vector<Index> grouped = offset_grouped(bi, bj, rank.size());
  const std::size_t affine = affine_bonds(grouped, bi, bj);
  if (2 * affine >= scene_bonds) return {rank_of(grouped), affine};
  std::vector<std::uint64_t> key(scene_bonds);
  for (std::size_t b = 0; b < scene_bonds; ++b) key[b] = std::uint64_t{bi[b]} << 32 | bj[b];
  return {rank_by(key), affine};
}

}  // namespace

Renumbering locality_order(const World& world) {
  const Model& m = world.model;
  const State& s = world.state;
  const std::size_t n = m.num_quanta(), nb = s.bonds.size(), scene_bonds = s.bonds.first_formed;
  Renumbering r;
  if (n == 0) return r;

  Vec3 lo = s.x[0], hi = s.x[0];
  for (const Vec3& x : s.x) {
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  constexpr double kMaxBin = (1u << 21) - 1;  // 21 bits a coordinate
  const double extent = (hi - lo).maxCoeff();
  // Bins one spacing wide, centred on lo + k·spacing so that a lattice's rows sit mid-bin
  // (round-off cannot move a quanta to the next row).
  double bin = extent > 0 ? std::max(spacing(m, s, extent), extent / kMaxBin) : 1.0;
  if (!(bin > 0 && std::isfinite(bin))) bin = 1.0;
  std::vector<std::uint64_t> key(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 c = ((s.x[i] - lo) / bin).array() + 0.5;
    // Non-finite positions (a scene cannot make them; a hand-built world might) sort last.
    if (!c.allFinite()) {
      key[i] = ~std::uint64_t{0};
      continue;
    }
    const Vec3 q = c.cwiseMax(0.0).cwiseMin(kMaxBin);
    key[i] = std::uint64_t(q.z()) << 42 | std::uint64_t(q.y()) << 21 | std::uint64_t(q.x());
  }
  r.quanta = rank_by(key);
  BondOrder bonds = bond_order(s.bonds, r.quanta, scene_bonds);
  // A body built as a lattice and then rotated is numbered row by row in its own axes, which bins
  // in the world's axes scramble: its bonds then form no affine runs and every bond kernel takes
  // its per-bond path. Keep the given numbering when its bonds form more affine runs.
  std::vector<Index> same(n);
  std::iota(same.begin(), same.end(), Index{0});
  if (bonds.affine < scene_bonds && r.quanta != same) {
    if (BondOrder kept = bond_order(s.bonds, same, scene_bonds); kept.affine > bonds.affine) {
      r.quanta = std::move(same);
      bonds = std::move(kept);
    }
  }
  r.bonds = std::move(bonds.rank);
  for (std::size_t b = scene_bonds; b < nb; ++b) r.bonds.push_back(static_cast<Index>(b));
  return r;
}

std::vector<Index> quanta_by_id(const Model& model) { return inverse(model.quanta_id); }
std::vector<Index> bonds_by_id(const Bonds& bonds) { return inverse(bonds.id); }

void renumber_quanta(std::vector<Index>& quanta, const Renumbering& r) {
  for (Index& i : quanta) i = r.quanta[i];
}

void renumber(World& world, const Renumbering& r) {
  Model& m = world.model;
  State& s = world.state;
  [[maybe_unused]] const std::size_t n = m.num_quanta();
  const std::size_t nb = s.bonds.size();
  assert(r.quanta.size() == n && r.bonds.size() == nb);
  for (std::size_t b = s.bonds.first_formed; b < nb; ++b) assert(r.bonds[b] == b);  // formed keep slots

  permute(m.mass, r.quanta);
  permute(m.inv_mass, r.quanta);
  permute(m.body, r.quanta);
  permute(m.volume, r.quanta);
  permute(m.quanta_id, r.quanta);
  permute(s.x, r.quanta);
  permute(s.v, r.quanta);
  if (auto* g = std::get_if<SolverGuess>(&s.carry)) {
    permute(g->dv, r.quanta);
  } else if (auto* p = std::get_if<SolverGuessPair>(&s.carry)) {
    permute(p->dv, r.quanta);
    permute(p->dv_before, r.quanta);
  } else if (auto* b = std::get_if<Bdf2History>(&s.carry)) {
    permute(b->x, r.quanta);
    permute(b->v, r.quanta);
  } else {
    s.carry = std::monostate{};  // velocity_verlet's forces: the new topology version would drop them anyway
  }
  for (Motion& motion : m.motions) renumber_quanta(motion.quanta, r);
  for (Load& load : m.loads) renumber_quanta(load.quanta, r);

  Bonds& bonds = s.edit_bonds();
  renumber_quanta(bonds.i, r);
  renumber_quanta(bonds.j, r);
  permute(bonds.i, r.bonds);
  permute(bonds.j, r.bonds);
  permute(bonds.id, r.bonds);
  permute(bonds.law, r.bonds);
  permute(bonds.damping_model, r.bonds);
  permute(bonds.strength, r.bonds);
  permute(bonds.damping, r.bonds);
  permute(bonds.rest0, r.bonds);
  permute(bonds.shape, r.bonds);
  permute(bonds.rest, r.bonds);
  permute(bonds.alive, r.bonds);
  permute(bonds.time, r.bonds);
}

}  // namespace qbond
