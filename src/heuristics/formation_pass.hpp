#pragma once
// One pass of a formation rule over quanta at given positions (formation.cpp): the rule's
// heuristic takes every quanta at its projected end, a run over ranks the quanta near others
// gathered from every rank (distributed_step.cpp), both in increasing whole index.
#include <cstdint>
#include <span>
#include <unordered_set>
#include <vector>

#include "heuristics/spatial_hash.hpp"
#include "qbond/heuristics/formation.hpp"

namespace qbond {

class FormationPass {
 public:
  // Bonds, as `rule` with `law` (its bond law in m's shapes), the pairs of quanta closer than its
  // capture radius at positions `pos`, in increasing first quanta then grid order: position a is
  // quanta ids[a] of m and s (ids increasing; empty: a itself). Counts from s's bonds (adj: its
  // alive ones), charges the new bonds' energy to s's books and appends the events (`step`: the
  // step they are made in). Returns how many bonds it made.
  std::size_t run(const FormRule& rule, const BondLaw& law, const Model& m, State& s, const Adjacency& adj,
                  const std::vector<Vec3>& pos, std::span<const Index> ids, const StepContext& step,
                  std::vector<BondEvent>& events);

 private:
  SpatialHash grid_;
  std::vector<Index> degree_, free_;
  std::vector<std::pair<Index, Index>> pairs_;
  std::unordered_set<std::uint64_t> recent_;
};

}  // namespace qbond
