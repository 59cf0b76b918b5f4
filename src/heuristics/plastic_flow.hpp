#pragma once
// How a plastic rule flows the bonds at the projected end of a step: the plastic heuristic's
// flow, apart from its ductile breaks, so that a run over ranks can flow the bonds each rank owns
// and break them as the run alone does (docs/distributed.md).
#include <cstdint>
#include <vector>

#include "qbond/heuristics/fracture.hpp"

namespace qbond {

class PlasticFlow {
 public:
  // What the flow did to a bond: rest length kept, flowed, or flowed past the ductility limit.
  enum : std::uint8_t { kKept, kFlowed, kDuctile };
  // Sets the rest length of each alive bond of s that `rule` covers to plastic_rest_length at the
  // projected positions x + dx, and charges the elastic energy the flow releases, U(L) − U(L₁)
  // summed in bond order, to s.energy.dissipated_heuristics. Returns per bond kKept, kFlowed or
  // kDuctile (the caller breaks those). Independent per bond: parallel on `threads`.
  const std::vector<std::uint8_t>& flow(const PlasticRule& rule, const Model& m, State& s, const Projection& p,
                                        int threads);

 private:
  std::vector<std::uint8_t> edit_;
};

}  // namespace qbond
