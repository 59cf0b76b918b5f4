#include "menus.hpp"

namespace qbond::view {

Menu<IntegratorType> integrator_menu() {
  Menu<IntegratorType> m;
  for (const IntegratorInfo& i : integrator_table()) {
    m.names.emplace_back(i.key);
    m.values.push_back(i.type);
  }
  return m;
}

Menu<NeighbourModel> neighbour_menu() {
  Menu<NeighbourModel> m;
  for (const NamedValue<NeighbourModel>& n : neighbour_models()) {
    m.names.emplace_back(n.key);
    m.values.push_back(n.value);
  }
  return m;
}

Menu<CoupledSolver> solver_menu(IntegratorType t) {
  Menu<CoupledSolver> m;
  for (CoupledSolver s : integrator_info(t).solvers) {
    m.names.emplace_back(to_string(s));
    m.values.push_back(s);
  }
  return m;
}

Menu<Preconditioner> preconditioner_menu() {
  Menu<Preconditioner> m;
  for (const NamedValue<Preconditioner>& p : preconditioners()) {
    m.names.emplace_back(p.key);
    m.values.push_back(p.value);
  }
  return m;
}

}  // namespace qbond::view
