// The Python module qbond._core (python/qbond/__init__.py re-exports it as `qbond`).
#include "bindings.hpp"

#include "qbond/version.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() = "qbond: a quanta-bond physics engine (point masses, bonds, implicit integrators).";
  m.attr("__version__") = QBOND_VERSION;
  m.def("version", [] { return std::string(qbond::version()); }, "The version of the qbond library linked in.");
  qbond::python::bind_errors(m);
  qbond::python::bind_world(m);
  qbond::python::bind_scene(m);
  qbond::python::bind_simulation(m);
}
