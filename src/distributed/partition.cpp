#include "distributed/partition.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace qbond::distributed {

int Bisection::part_of(const Vec3& x) const {
  int k = 0;
  while (nodes[k].part < 0) k = x[nodes[k].axis] < nodes[k].cut ? nodes[k].left : nodes[k].right;
  return nodes[k].part;
}

void Bisection::box(int p, Vec3& lo, Vec3& hi) const {
  lo = Vec3::Constant(-HUGE_VAL);
  hi = Vec3::Constant(HUGE_VAL);
  // Down the path to p's leaf: each cut on it bounds p's box on one side.
  auto holds = [&](auto&& self, int k) -> bool {
    const Node& n = nodes[static_cast<std::size_t>(k)];
    if (n.part >= 0) return n.part == p;
    if (self(self, n.left)) {
      hi[n.axis] = std::min(hi[n.axis], n.cut);  // the left box is x[axis] < cut
      return true;
    }
    if (self(self, n.right)) {
      lo[n.axis] = std::max(lo[n.axis], n.cut);
      return true;
    }
    return false;
  };
  holds(holds, 0);
}

namespace {

// Builds the subtree of parts [first, first + parts) over the points `idx`; returns its node.
int build(std::span<const Vec3> x, std::vector<Index>& idx, int first, int parts, Bisection& b) {
  const int self = static_cast<int>(b.nodes.size());
  b.nodes.emplace_back();
  if (parts == 1) {
    b.nodes[self].part = first;
    return self;
  }
  const int left_parts = parts / 2;
  Vec3 lo = Vec3::Constant(HUGE_VAL), hi = Vec3::Constant(-HUGE_VAL);
  for (Index i : idx) {
    lo = lo.cwiseMin(x[i]);
    hi = hi.cwiseMax(x[i]);
  }
  // The longest side first (the lowest axis of equal ones); an axis whose points all share one
  // coordinate cannot be cut, and then the next longest is tried.
  std::array<int, 3> axes{0, 1, 2};
  const Vec3 extent = idx.empty() ? Vec3::Zero() : Vec3(hi - lo);
  std::stable_sort(axes.begin(), axes.end(), [&](int a, int c) { return extent[a] > extent[c]; });
  int axis = axes[0];
  double cut = HUGE_VAL;  // no cut: every point goes right (the left parts are empty)
  const std::size_t target = idx.size() * static_cast<std::size_t>(left_parts) / static_cast<std::size_t>(parts);
  for (int a : axes) {
    if (!(extent[a] > 0)) break;
    // Sorted by coordinate, then by index: a total order, so the cut is the same on every rank.
    std::sort(idx.begin(), idx.end(), [&](Index p, Index q) { return x[p][a] < x[q][a] || (x[p][a] == x[q][a] && p < q); });
    // The distinct pair of neighbouring coordinates nearest the target count, cut halfway between
    // them: points then sit at least half a gap from the cut and cross it only by moving.
    std::size_t best = 0;
    for (std::size_t k = 1; k < idx.size(); ++k) {
      if (x[idx[k - 1]][a] == x[idx[k]][a]) continue;
      const auto dist = [&](std::size_t m) { return m > target ? m - target : target - m; };
      if (best == 0 || dist(k) < dist(best)) best = k;
    }
    if (best == 0) continue;
    axis = a;
    cut = 0.5 * (x[idx[best - 1]][a] + x[idx[best]][a]);
    break;
  }
  std::vector<Index> left, right;
  for (Index i : idx) (x[i][axis] < cut ? left : right).push_back(i);
  std::sort(left.begin(), left.end());
  std::sort(right.begin(), right.end());
  b.nodes[self].axis = axis;
  b.nodes[self].cut = cut;
  const int l = build(x, left, first, left_parts, b);
  const int r = build(x, right, first + left_parts, parts - left_parts, b);
  b.nodes[self].left = l;
  b.nodes[self].right = r;
  return self;
}

}  // namespace

Bisection bisect(std::span<const Vec3> x, int parts) {
  Bisection b;
  b.parts = std::max(1, parts);
  std::vector<Index> idx(x.size());
  std::iota(idx.begin(), idx.end(), Index{0});
  build(x, idx, 0, b.parts, b);
  return b;
}

std::vector<int> parts_of(const Bisection& b, std::span<const Vec3> x) {
  std::vector<int> p(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) p[i] = b.part_of(x[i]);
  return p;
}

std::string bisection_json(const Bisection& b, const Strays& strays) {
  nlohmann::json nodes = nlohmann::json::array();
  for (const Bisection::Node& n : b.nodes)
    nodes.push_back({n.part, n.axis, std::isfinite(n.cut) ? nlohmann::json(n.cut) : nlohmann::json(), n.left, n.right});
  nlohmann::json j{{"parts", b.parts}, {"nodes", nodes}};
  if (!strays.empty()) j["strays"] = strays;
  return j.dump();
}

Bisection bisection_from_json(const std::string& text, Strays* strays) {
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  auto fail = [](const std::string& why) { throw std::invalid_argument("ranks: " + why); };
  if (!j.is_object() || !j.contains("parts") || !j.contains("nodes") || !j["parts"].is_number_integer() ||
      !j["nodes"].is_array())
    fail("expected {\"parts\": N, \"nodes\": [...]}");
  for (const auto& [key, value] : j.items())
    if (key != "parts" && key != "nodes" && key != "strays") fail("unknown key '" + key + "'");
  Bisection b;
  b.parts = j["parts"].get<int>();
  const nlohmann::json& nodes = j["nodes"];
  if (b.parts < 1 || nodes.size() != 2 * static_cast<std::size_t>(b.parts) - 1)
    fail("a bisection into " + std::to_string(b.parts) + " parts has 2 parts - 1 nodes, not " +
         std::to_string(nodes.size()));
  const int count = static_cast<int>(nodes.size());
  std::vector<int> leaves(static_cast<std::size_t>(b.parts), 0);
  for (int k = 0; k < count; ++k) {
    const nlohmann::json& n = nodes[static_cast<std::size_t>(k)];
    const std::string at = "nodes[" + std::to_string(k) + "]: ";
    if (!n.is_array() || n.size() != 5 || !n[0].is_number_integer() || !n[1].is_number_integer() ||
        !(n[2].is_number() || n[2].is_null()) || !n[3].is_number_integer() || !n[4].is_number_integer())
      fail(at + "expected [part, axis, cut, left, right]");
    Bisection::Node node{n[0].get<int>(), n[1].get<int>(), n[2].is_null() ? HUGE_VAL : n[2].get<double>(),
                         n[3].get<int>(), n[4].get<int>()};
    // Nodes come parent before children (no cycle); a leaf is one part, each part one leaf.
    const bool leaf = node.part >= 0;
    if (leaf ? node.part >= b.parts || leaves[static_cast<std::size_t>(node.part)]++ > 0
             : node.part != -1 || node.axis < 0 || node.axis > 2 || !(node.cut > -HUGE_VAL) || node.left <= k ||
                   node.right <= k || node.left >= count || node.right >= count)
      fail(at + "not a node of a bisection");
    b.nodes.push_back(node);
  }
  if (j.contains("strays")) {
    const nlohmann::json& s = j["strays"];
    if (!s.is_array()) fail("strays: expected [[point, part], ...]");
    for (std::size_t k = 0; k < s.size(); ++k) {
      const nlohmann::json& e = s[k];
      if (!e.is_array() || e.size() != 2 || !e[0].is_number_unsigned() || !e[1].is_number_integer() ||
          e[1].get<int>() < 0 || e[1].get<int>() >= b.parts)
        fail("strays[" + std::to_string(k) + "]: expected [point, part] with a part below " + std::to_string(b.parts));
      if (strays) strays->emplace_back(e[0].get<Index>(), e[1].get<int>());
    }
  }
  return b;
}

}  // namespace qbond::distributed
