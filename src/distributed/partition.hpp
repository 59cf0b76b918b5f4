#pragma once
// Recursive coordinate bisection: the world split in space into one box per rank. Each node of
// the tree cuts its points along the longest side of their bounding box, between two distinct
// coordinates, so that its two halves hold points in proportion to their ranks; a point's part is
// then found by walking the tree (part_of), which is how quanta that moved find their new owner.
#include <span>
#include <string>
#include <vector>

#include "qbond/core/math.hpp"

namespace qbond::distributed {

struct Bisection {
  // A node: a leaf is one part; an inner node sends x[axis] < cut to `left`, the rest to `right`.
  struct Node {
    int part = -1;  // the leaf's part, else -1
    int axis = 0;
    double cut = 0;
    int left = -1, right = -1;  // children (indices into nodes)
  };
  std::vector<Node> nodes;  // nodes[0] is the root
  int parts = 1;

  // The part whose box holds x.
  int part_of(const Vec3& x) const;
  // Part p's box, [lo, hi) on each axis (infinite where no cut bounds it).
  void box(int p, Vec3& lo, Vec3& hi) const;
};

// Points held by another part than the one whose box holds them: [point, part] each.
using Strays = std::vector<std::pair<Index, int>>;

// The bisection of the points x into `parts` parts (>= 1): the same for the same points, whatever
// their count per part. Parts may be empty when the points cannot be split (all at one place).
Bisection bisect(std::span<const Vec3> x, int parts);

// The part of every point (Bisection::part_of).
std::vector<int> parts_of(const Bisection& b, std::span<const Vec3> x);

// The bisection as JSON, {"parts": N, "nodes": [[part, axis, cut, left, right], ...]} (a cut
// that sends every point right is null), with "strays": [[point, part], ...] when there are
// any, and back (the strays into `strays` when given); bisection_from_json throws
// std::invalid_argument saying what is wrong when the text is not one.
std::string bisection_json(const Bisection& b, const Strays& strays = {});
Bisection bisection_from_json(const std::string& text, Strays* strays = nullptr);

}  // namespace qbond::distributed
