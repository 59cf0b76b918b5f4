#include "integrators/bond_partition.hpp"

#include <algorithm>
#include <cassert>

#include "integrators/affine_run_terms.hpp"

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

// Every alive bond's part runs (BondPartition::runs): affine segments cut into runs of at most
// kBondRun, the other bonds in runs of at most kBondRun consecutive listed bonds that do not
// cross a segment.
void build_runs(BondPartition& part, const Bonds& bonds, const Adjacency& adj) {
  struct Segment {
    Index first, end;
  };
  std::vector<Segment> segments;
  const auto nb = static_cast<Index>(part.num_bonds);
  std::vector<std::uint8_t>& alive = part.mark;  // the adjacency holds exactly the alive bonds
  alive.assign(nb, 0);
  for (Index b : adj.bond) alive[b] = 1;
  for_each_affine_segment(bonds.i.data(), bonds.j.data(), nb, kMinAffineRun,
                          [&](Index b) { return alive[b] != 0; },
                          [&](Index b, Index n) { segments.push_back({b, b + n}); });
  alive.clear();

  const int parts = part.parts();
  part.runs.clear();
  part.run_offset.assign(static_cast<std::size_t>(parts) + 1, 0);
  for (int p = 0; p < parts; ++p) {
    const Index lo = part.first[p], hi = part.first[p + 1];
    auto consecutive = [&](const Index* list, Index first, Index count) {
      part.runs.push_back({list, first, count, lo, hi, false, false, 0, 0});
    };
    // The chunks of segment [s, end) that hold bonds first .. last. A segment is cut into
    // chunks of kBondRun at fixed offsets from its start, the same for every partition, so that
    // the kernels' choice of path for a chunk (hybrid_frozen_kernel.cpp) does not depend on the thread
    // count. A chunk's loops may read the bonds after it up to affine_lanes: one that would
    // pass the last bond goes to the per-bond path.
    auto affine = [&](Index s, Index end, Index first, Index last) {
      for (Index b = s + (first - s) / kBondRun * kBondRun; b <= last; b += kBondRun) {
        const Index count = std::min(kBondRun, end - b);
        const bool padded = b + affine_lanes(count) <= nb;
        part.runs.push_back({nullptr, b, count, lo, hi, false, padded, bonds.i[s] + (b - s),
                             bonds.j[s] + (b - s)});
      }
    };
    std::size_t seg = 0;
    if (part.all_in_one) {
      for (Index b = 0; b < nb;) {
        const Index stop = seg < segments.size() ? segments[seg].first : nb;
        for (; b < stop; b += std::min(kBondRun, stop - b)) consecutive(nullptr, b, std::min(kBondRun, stop - b));
        if (seg < segments.size()) {
          affine(segments[seg].first, segments[seg].end, segments[seg].first, segments[seg].end - 1);
          b = segments[seg++].end;
        }
      }
    } else {
      const Index* list = part.bonds.data();
      for (Index k = part.offset[p], end = part.offset[p + 1]; k < end;) {
        const Index b = list[k];
        while (seg < segments.size() && segments[seg].end <= b) ++seg;
        Index k2 = k;
        if (seg < segments.size() && segments[seg].first <= b) {
          while (k2 < end && list[k2] < segments[seg].end) ++k2;
          affine(segments[seg].first, segments[seg].end, b, list[k2 - 1]);
        } else {
          const Index stop = seg < segments.size() ? segments[seg].first : nb;
          while (k2 < end && k2 - k < kBondRun && list[k2] < stop) ++k2;
          consecutive(list + k, 0, k2 - k);
        }
        k = k2;
      }
    }
    part.run_offset[p + 1] = static_cast<Index>(part.runs.size());
    if (part.run_offset[p + 1] > part.run_offset[p]) part.runs.back().last = true;
  }
}

// Each run's reach and settled mark (BondRun), from the last run of each part back, and the
// quanta each part has alone (BondPartition::alone_lo, alone_hi).
void mark_reach(BondPartition& part, const Bonds& bonds) {
  const int parts = part.parts();
  // The quanta part p's runs join lie in [joins_lo[p], joins_hi[p]) (empty for a part without runs).
  std::vector<Index> joins_lo(part.first.begin() + 1, part.first.end());
  std::vector<Index> joins_hi(part.first.begin(), part.first.end() - 1);
  for (int p = 0; p < parts; ++p) {
    const Index hi = part.first[p + 1];
    Index below = hi;  // the lowest quanta the part's later runs join (hi: none)
    for (Index r = part.run_offset[p + 1]; r-- > part.run_offset[p];) {
      BondRun& run = part.runs[r];
      run.settled = below;
      Index lo_end = run.affine ? std::min(run.i0, run.j0) : ~Index{0};
      Index hi_end = run.affine ? std::max(run.i0, run.j0) + affine_lanes(run.count) : 0;
      if (!run.affine)
        for (Index k = 0; k < run.count; ++k) {
          const Index b = run.bond(k), i = bonds.i[b], j = bonds.j[b];
          lo_end = std::min({lo_end, i, j});
          hi_end = std::max({hi_end, i + 1, j + 1});
        }
      run.reach = hi_end;
      below = std::min(below, lo_end);
      joins_hi[p] = std::max(joins_hi[p], hi_end);
    }
    joins_lo[p] = below;
  }
  // The ranges are contiguous: the parts before p join quanta up to the highest of their joins_hi,
  // the parts after it from the lowest of their joins_lo.
  part.alone_lo.resize(static_cast<std::size_t>(parts));
  part.alone_hi.resize(static_cast<std::size_t>(parts));
  Index below = 0;
  for (int p = 0; p < parts; ++p) {
    part.alone_lo[p] = std::clamp(below, part.first[p], part.first[p + 1]);
    below = std::max(below, joins_hi[p]);
  }
  Index above = part.first[parts];
  for (int p = parts; p-- > 0;) {
    part.alone_hi[p] = std::max(part.alone_lo[p], std::min(part.first[p + 1], above));
    above = std::min(above, joins_lo[p]);
  }
}

// Each part's grids (BondRun::rows).
void mark_grids(BondPartition& part) {
  std::vector<BondRun>& runs = part.runs;
  auto next_row = [](const BondRun& a, const BondRun& b, Index stride) {
    return b.affine && b.count == a.count && b.first == a.first + a.count && b.i0 == a.i0 + stride &&
           b.j0 == a.j0 + stride;
  };
  for (int p = 0; p < part.parts(); ++p) {
    const Index end = part.run_offset[p + 1];
    for (Index r = part.run_offset[p]; r < end;) {
      Index e = r + 1;
      if (runs[r].affine && e < end && runs[e].i0 > runs[r].i0) {
        const Index stride = runs[e].i0 - runs[r].i0;
        while (e < end && next_row(runs[e - 1], runs[e], stride)) ++e;
      }
      runs[r].rows = e - r;
      r = e;
    }
  }
}

}  // namespace

void BondPartition::update(const Model& model, const Bonds& all, const Adjacency& adj, int threads_wanted) {
  const std::size_t n = model.num_quanta(), nb = all.size();
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
  num_quanta = n;
  num_bonds = nb;
  build_runs(*this, all, adj);
  mark_reach(*this, all);
  mark_grids(*this);
  for (BondRun& run : runs) run.kind = static_cast<std::int8_t>(run.affine ? uniform_linear(all, run) : -1);
  version = adj.version;
  threads = threads_wanted;
}

}  // namespace qbond
