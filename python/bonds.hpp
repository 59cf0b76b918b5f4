#pragma once
// Everything the module reads of or writes to the bonds: kept in one file (bonds.cpp) so that a
// change to where the library stores per-bond arrays touches only it.
#include "bindings.hpp"

#include "qbond/model/world.hpp"

namespace qbond::python {

/// A bond's parameters from their Python names; throws ValueError naming a bad one.
BondSpec bond_spec(const std::string& law, double stiffness, double damping, const std::string& damping_model,
                   double rest_length, const py::object& shape);
/// (nb, 2) array of the bonds' end quanta (a copy: the ends are two arrays in the library).
py::array_t<std::int64_t> bond_ends(const World& w);
/// (nb,) bool array: whether each bond holds (a copy).
py::array_t<bool> bond_alive(const World& w);
/// (nb,) arrays of each bond's stiffness parameter and rest length (copies).
py::array_t<double> bond_stiffness(const World& w);
py::array_t<double> bond_rest_length(const World& w);
/// (nb,) tension [N] and strain (r − L)/L of every bond, 0 for broken ones (copies).
py::tuple bond_tension_strain(const World& w);
/// (n, 3) net bond force on every quanta [N], elastic and damping, at the current state.
py::array_t<double> bond_forces(const World& w);

}  // namespace qbond::python
