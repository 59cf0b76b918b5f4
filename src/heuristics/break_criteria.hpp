#pragma once
// Which bonds a break rule finds over one of its thresholds at the projected end of a step: the
// break heuristic's test, apart from its draws and breaks, so that a run over ranks can test the
// bonds each rank owns and draw in the whole world's bond order (docs/distributed.md).
#include <cstdint>
#include <span>
#include <vector>

#include "qbond/heuristics/fracture.hpp"

namespace qbond {

class BreakCriteria {
 public:
  // The reason of a bond not over any threshold.
  static constexpr std::uint8_t kNone = 0xff;
  // Per bond of s: the BondEvent::Reason it is over one of rule's thresholds at the projected
  // positions x + dx, or kNone (dead bonds, bonds the rule does not select, bonds past their law's
  // failure stretch, which the step breaks itself). Independent per bond: parallel on `threads`.
  // The stress limits read each quanta's virial stress at the projected state, from s's bonds,
  // or `stress` when given (per quanta of s: a run over ranks gives its ghosts their owners').
  const std::vector<std::uint8_t>& evaluate(const BreakRule& rule, const Model& m, const State& s,
                                            const Projection& p, int threads, std::span<const Mat3> stress = {});

 private:
  std::vector<std::uint8_t> why_;
  std::vector<Vec3> x_, v_;  // projected state, for the stress criteria
  std::vector<Mat3> sigma_;
};

}  // namespace qbond
