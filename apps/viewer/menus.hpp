#pragma once
/// The panel's integrator menus, taken from the integrator table (integrators.hpp): every
/// integrator by name, and for the chosen one the values of the options it reads.
#include <string>
#include <vector>

#include "qbond/integrators/integrators.hpp"

namespace qbond::view {

/// A menu of values by name, as ImGui::Combo takes it.
template <class E>
struct Menu {
  std::vector<std::string> names;
  std::vector<E> values;
  /// The names as C strings (valid while the menu lives).
  std::vector<const char*> labels() const {
    std::vector<const char*> out;
    for (const std::string& n : names) out.push_back(n.c_str());
    return out;
  }
  /// The entry showing `e` (0 when it is not in the menu).
  int index(E e) const {
    for (std::size_t k = 0; k < values.size(); ++k)
      if (values[k] == e) return static_cast<int>(k);
    return 0;
  }
};

/// Every integrator of the table, in its order.
Menu<IntegratorType> integrator_menu();
/// Every neighbour model.
Menu<NeighbourModel> neighbour_menu();
/// The solvers integrator `t` takes (empty when it reads none).
Menu<CoupledSolver> solver_menu(IntegratorType t);
/// Every preconditioner of CG.
Menu<Preconditioner> preconditioner_menu();

}  // namespace qbond::view
