#pragma once
// Bond-centric passes that update both ends of every bond in one sweep over the bonds, with the
// same bits for any thread count.
//
// The quanta are split into contiguous ranges, one per thread. A thread visits, in increasing
// bond order, every alive bond with an end in its range and updates only those ends. Each quanta
// therefore receives its bonds' contributions in bond order whatever the thread count, exactly as
// a serial pass over the bonds gives them; a bond whose ends lie in two ranges is evaluated by
// both threads, identically. Compared with computing per-bond records and gathering them per
// quanta, the bonds are streamed once and only per-quanta data is touched at random, which for
// builder-ordered bonds stays within a window of a few lattice planes (in cache).
#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include "core/parallel.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

// A run of at most kBondRun alive bonds, in increasing order, from one part of a partition: the
// bonds list[0..count), or first .. first + count - 1 when list is null. An affine run (list
// null) is a piece of an affine segment (for_each_affine_segment): bond first + k joins
// i0 + k and j0 + k, so that its ends' data are contiguous; bonds exist up to affine_lanes(count)
// (vector loops over an affine run need no remainder). The part updates the
// ends in [lo, hi) only; `last` marks its last run. `reach` is one past the highest quanta the
// run's bonds (an affine run's whole lanes) join, and the part's rows below `settled` receive
// nothing from its later runs (set by BondPartition::update).
inline constexpr Index kBondRun = 64;
struct BondRun {
  const Index* list;
  Index first, count, lo, hi;
  bool last;
  bool affine;
  Index i0, j0;
  Index reach = 0, settled = 0;
  // How many runs from this one form a grid (1: none): affine runs of the same count, each taking
  // the bonds after the one before's, its ends the same number of quanta further on (a small
  // body's rows of one offset: cube_drop's 120 runs are 16 grids and 2 runs). Kernels may take a
  // grid's runs in one loop, with what does not change from run to run set up once.
  Index rows = 1;
  // An affine run's uniform_linear (affine_run_terms.hpp) when the partition was built: 0 every bond
  // linear with axial damping, 1 with isotropic, −1 otherwise or not affine (the per-bond path).
  // Kept, not tested each pass: reading each bond's law and damping model is 2 bytes a bond more
  // from memory, and they change only with the topology (World::form_bond).
  std::int8_t kind = -1;
  Index bond(Index k) const { return list ? list[k] : first + k; }
  bool owns(Index q) const { return q >= lo && q < hi; }
};

// What counts as a lattice's affine segment when choosing a numbering (ordering.hpp): as long as
// one vector of the kernels' affine runs (4 lanes). With 8 (an AVX-512 register), a body of 5³
// (rows of 4 bonds) would get no affine runs, and every bond of it would take the much slower
// per-bond path.
inline constexpr Index kMinAffine = 4;
// The shortest segment the kernels take as an affine run: the vector path runs whole vectors
// (padded lanes), so even two bonds cost one vector iteration, far less than the per-bond
// path's gathers and per-run set-up.
inline constexpr Index kMinAffineRun = 2;

// The lanes the vector path takes for an affine run of `count` bonds: count rounded up to a
// multiple of 4, run as vectors of 8 and at most one of 4 (affine_run_terms.hpp, for_lanes). Rounding
// to 4 rather than 8 matters for short runs: a 10³ lattice's rows give runs of 9 bonds, which
// take 12 lanes instead of 16.
inline Index affine_lanes(Index count) { return (count + 3) & ~Index{3}; }

// segment(b, count) for every maximal run of at least min_length consecutive alive bonds
// b, b + 1, ... whose ends advance together: bond b + k joins bond_i[b] + k and bond_j[b] + k.
// A lattice whose bonds are grouped by index offset (ordering.hpp) is made of such runs.
template <class Alive, class Segment>
void for_each_affine_segment(const Index* bond_i, const Index* bond_j, Index nb, Index min_length, Alive&& alive,
                             Segment&& segment) {
  for (Index b = 0; b < nb;) {
    if (!alive(b)) {
      ++b;
      continue;
    }
    Index n = 1;
    while (b + n < nb && alive(b + n) && bond_i[b + n] == bond_i[b] + n && bond_j[b + n] == bond_j[b] + n) ++n;
    if (n >= min_length) segment(b, n);
    b += n;  // a run starting inside this one ends where it does, shorter
  }
}

struct BondPartition {
  std::vector<Index> first;   // (parts + 1): part p owns quanta [first[p], first[p + 1])
  std::vector<Index> offset;  // (parts + 1): part p visits bonds[offset[p] .. offset[p + 1])
  std::vector<Index> bonds;   // per part, its alive bonds with an end in its range, increasing
  // Per part, runs[run_offset[p] .. run_offset[p + 1]): its bonds (as listed, or all of them
  // when all_in_one) in runs for for_each_bond_run, affine where the bonds form affine
  // segments. Segments are cut into runs at fixed offsets from their start, the same runs for
  // every partition; a part visits every run of a segment from the one holding its first bond
  // with an owned end to the one holding its last (the bonds there with no owned end change
  // nothing).
  std::vector<BondRun> runs;
  std::vector<Index> run_offset;
  // (parts): part p's quanta that no other part's runs join (an affine run's whole lanes
  // included), [alone_lo[p], alone_hi[p]): a kernel may write those while the other parts run.
  std::vector<Index> alone_lo, alone_hi;
  std::vector<std::uint8_t> mark;  // scratch of update
  // One part and every bond alive: for_each_bond visits bonds 0..nb-1 and the lists are not
  // built (offset all 0, bonds empty).
  bool all_in_one = false;
  std::uint64_t version = ~0ull;
  std::size_t num_quanta = 0, num_bonds = 0;
  int threads = -1;

  // Rebuilds for the adjacency's topology (its alive bonds) and the thread count if either
  // changed: ranges balanced by bond ends, one part below kParallelMin quanta. O(bonds × parts).
  void update(const Model& model, const Bonds& all, const Adjacency& adj, int threads);
  int parts() const { return static_cast<int>(first.size()) - 1; }
};

// run(p) for each part p, each on its own thread (the calling one when there is one part:
// parallel_for says why).
template <class Run>
void for_each_part(int parts, Run&& run) {
#ifdef _OPENMP
  if (parts > 1) {
#pragma omp parallel for schedule(static, 1) num_threads(parts)
    for (int p = 0; p < parts; ++p) run(p);
    return;
  }
#endif
  for (int p = 0; p < parts; ++p) run(p);
}

// body(b, i_owned, j_owned) for every alive bond b, where i_owned / j_owned say whether this call
// may update bond_i[b] / bond_j[b]; each end of each bond is owned in exactly one call, and the
// calls owning a given quanta come in increasing b.
template <class Body>
void for_each_bond(const BondPartition& part, const Bonds& bonds, Body&& body) {
  if (part.all_in_one) {  // the single-thread pass over intact bonds: every end is owned
    for (Index b = 0; b < static_cast<Index>(part.num_bonds); ++b) body(b, true, true);
    return;
  }
  const int parts = part.parts();
  const Index* bi = bonds.i.data();
  const Index* bj = bonds.j.data();
  auto run = [&](int p) {
    const Index lo = part.first[p], hi = part.first[p + 1];
    for (Index k = part.offset[p]; k < part.offset[p + 1]; ++k) {
      const Index b = part.bonds[k];
      const Index i = bi[b], j = bj[b];
      body(b, i >= lo && i < hi, j >= lo && j < hi);
    }
  };
  for_each_part(parts, run);
}

// body(runs, scratch) once per part, with the part's runs in bond order, on the part's thread,
// with one Scratch (default-initialised) for the part: the runs cover every alive bond once per
// part that owns one of its ends (as for_each_bond visits them). For kernels that compute a run's
// per-bond terms in vectorised loops before updating the ends: a kernel compiled for several
// instruction sets (simd.hpp) takes a part's runs in one call, since a small body's runs are a
// vector or two each (cube_drop: 105 of its 120 affine runs have 4 bonds), and a call and its
// set-up a run cost as much as the run's arithmetic.
template <class Scratch, class Body>
void for_each_part_runs(const BondPartition& part, Body&& body) {
  for_each_part(part.parts(), [&](int p) {
    Scratch scratch;
    const Index r0 = part.run_offset[p], r1 = part.run_offset[p + 1];
    body(std::span<const BondRun>(part.runs.data() + r0, r1 - r0), scratch);
  });
}

// body(run, scratch) for each run of for_each_part_runs, one run at a time.
template <class Scratch, class Body>
void for_each_bond_run(const BondPartition& part, Body&& body) {
  for_each_part_runs<Scratch>(part, [&](std::span<const BondRun> runs, Scratch& scratch) {
    for (const BondRun& run : runs) body(run, scratch);
  });
}

}  // namespace qbond
