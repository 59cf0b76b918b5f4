#include "solvers/coloring.hpp"

#include <algorithm>

namespace qbond {

void color_free_quanta(const Model& model, const Adjacency& adj, Coloring& out) {
  const std::size_t n = model.num_quanta();
  std::vector<Index> color(n, kNone);
  std::vector<std::uint8_t> used;
  Index num_colors = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (model.is_kinematic(static_cast<Index>(i))) continue;
    used.assign(num_colors + 1, 0);
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
      const Index c = color[adj.other[e]];
      if (c != kNone) used[c] = 1;
    }
    const Index c = static_cast<Index>(std::find(used.begin(), used.end(), 0) - used.begin());
    color[i] = c;
    num_colors = std::max(num_colors, c + 1);
  }
  out.offset.assign(num_colors + 1, 0);
  for (std::size_t i = 0; i < n; ++i)
    if (color[i] != kNone) ++out.offset[color[i] + 1];
  for (Index c = 0; c < num_colors; ++c) out.offset[c + 1] += out.offset[c];
  out.quanta.resize(out.offset[num_colors]);
  std::vector<Index> fill(out.offset.begin(), out.offset.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    if (color[i] != kNone) out.quanta[fill[color[i]]++] = static_cast<Index>(i);
}

void free_components(const Model& model, const Adjacency& adj, FreeComponents& out) {
  const std::size_t n = model.num_quanta();
  std::vector<std::uint8_t> seen(n, 0);
  std::vector<Index> stack;
  out.offset.assign(1, 0);
  out.quanta.clear();
  out.mass.clear();
  for (std::size_t s = 0; s < n; ++s) {
    if (seen[s] || model.is_kinematic(static_cast<Index>(s))) continue;
    const std::size_t begin = out.quanta.size();
    bool touches_kinematic = false;
    double mass = 0;
    stack.assign(1, static_cast<Index>(s));
    seen[s] = 1;
    while (!stack.empty()) {
      const Index i = stack.back();
      stack.pop_back();
      out.quanta.push_back(i);
      mass += model.mass[i];
      for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
        const Index j = adj.other[e];
        if (model.is_kinematic(j)) {
          touches_kinematic = true;
        } else if (!seen[j]) {
          seen[j] = 1;
          stack.push_back(j);
        }
      }
    }
    if (touches_kinematic) {
      out.quanta.resize(begin);
    } else {
      std::sort(out.quanta.begin() + static_cast<std::ptrdiff_t>(begin), out.quanta.end());
      out.offset.push_back(static_cast<Index>(out.quanta.size()));
      out.mass.push_back(mass);
    }
  }
}

}  // namespace qbond
