#include "bond_partition.hpp"

#include <algorithm>
#include <cassert>

namespace qbond {

namespace {

// The per-part lists of alive bonds (BondPartition::offset, bonds) for its ranges.
void build_lists(BondPartition& part, const Adjacency& adj, int parts, std::size_t nb) {
  // The adjacency holds exactly the alive bonds: a part's are those of its quanta's entries,
  // marked, then listed in increasing order.
  std::vector<std::uint8_t>& mark = part.mark;
  mark.assign(nb, 0);
  for (int p = 0; p < parts; ++p) {
    for (Index e = adj.offset[part.first[p]]; e < adj.offset[part.first[p + 1]]; ++e) mark[adj.bond[e]] = 1;
    for (std::size_t b = 0; b < nb; ++b)
      if (mark[b]) {
        part.bonds.push_back(static_cast<Index>(b));
        mark[b] = 0;
      }
    part.offset[p + 1] = static_cast<Index>(part.bonds.size());
  }
}

}  // namespace


void BondPartition::update(const Model& model, const Adjacency& adj, int threads_wanted) {
  const std::size_t n = model.num_quanta(), nb = model.num_bonds();
  assert(adj.offset.size() == n + 1);
  if (version == adj.version && threads == threads_wanted && num_quanta == n && num_bonds == nb) return;
  const int parts = n < kParallelMin ? 1 : std::max(1, thread_count(threads_wanted));
  // Range boundaries at equal shares of the bond ends.
  first.assign(static_cast<std::size_t>(parts) + 1, 0);
  const auto ends = static_cast<std::size_t>(adj.offset[n]);
  for (int p = 1; p < parts; ++p) {
    const auto target = static_cast<Index>(ends * static_cast<std::size_t>(p) / static_cast<std::size_t>(parts));
    first[p] = static_cast<Index>(std::lower_bound(adj.offset.begin(), adj.offset.end() - 1, target) -
                                  adj.offset.begin());
  }
  first[parts] = static_cast<Index>(n);
  offset.assign(static_cast<std::size_t>(parts) + 1, 0);
  bonds.clear();
  mark.clear();
  // One part and every bond alive (each appears twice in the adjacency): for_each_bond walks the
  // bonds themselves and no list is needed.
  all_in_one = parts == 1 && ends == 2 * nb;
  if (!all_in_one) build_lists(*this, adj, parts, nb);
  version = adj.version;
  threads = threads_wanted;
  num_quanta = n;
  num_bonds = nb;
}

}  // namespace qbond
