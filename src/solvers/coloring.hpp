#pragma once
// Graph structure derived from the adjacency: colours for parallel Gauss–Seidel and the free
// connected components whose momentum change is known exactly.
#include <vector>

#include "qbond/model/world.hpp"

namespace qbond {

// Free quanta grouped by colour: no two bonded free quanta share a colour, so the quanta of one
// colour can be solved in any order (or in parallel) with identical results. Greedy colouring in
// id order: deterministic.
struct Coloring {
  std::vector<Index> offset;  // (colours + 1)
  std::vector<Index> quanta;  // free quanta, colour by colour, ascending id within a colour
  std::size_t num_colors() const { return offset.empty() ? 0 : offset.size() - 1; }
};
void color_free_quanta(const Model& model, const Adjacency& adj, Coloring& out);

// Connected components of free quanta (through alive bonds) that touch no kinematic quanta:
// bond forces cancel inside each, so its momentum changes by exactly h Σ f_ext over a step.
struct FreeComponents {
  std::vector<Index> offset;  // (components + 1)
  std::vector<Index> quanta;  // members, component by component
  std::vector<double> mass;   // total mass of each component [kg]
};
void free_components(const Model& model, const Adjacency& adj, FreeComponents& out);

}  // namespace qbond
