#pragma once
// What the point packings and the mesh lattices share: adding bonded points as a body, and
// numbers in their messages.
#include <charconv>
#include <string>
#include <utility>
#include <vector>

#include "qbond/builders/sampling.hpp"

namespace qbond {

/// The shortest text that reads back as v (for messages).
inline std::string num(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

/// Adds points x as quanta of `body` and bonds them by `pairs` (indices into x), first handling
/// the points no pair touches as `isolated` says (`what` names the builder in its message).
/// Returns the ids of the quanta added.
std::vector<Index> add_bonded_points(World& world, std::vector<Vec3> x, std::vector<std::pair<Index, Index>> pairs,
                                     double mass, const BondSpec& bond, Isolated isolated, Index body, const char* what);

}  // namespace qbond
