#pragma once
// The pieces of the Python module, one per file; module.cpp calls each bind_* in turn.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <vector>

#include "qbond/core/math.hpp"

namespace qbond::python {

namespace py = pybind11;

// errors.cpp: the module's exceptions and the translation of the library's.
void bind_errors(py::module_& m);
// scene.cpp: Scene (files, JSON text, dicts) and checkpoints.
void bind_scene(py::module_& m);
// world.cpp: World and its builders.
void bind_world(py::module_& m);
// simulation.cpp: Simulation.
void bind_simulation(py::module_& m);

// arrays.cpp: NumPy arrays of the library's vectors.
/// An (n, 3) float64 array viewing `v`'s storage (no copy); `owner` keeps that storage alive.
py::array_t<double> vec3_view(std::vector<Vec3>& v, py::handle owner, bool writable);
/// An (n,) array viewing `v`'s storage (no copy); `owner` keeps that storage alive.
template <class T>
py::array_t<T> view(std::vector<T>& v, py::handle owner, bool writable) {
  py::array_t<T> a({static_cast<py::ssize_t>(v.size())}, {static_cast<py::ssize_t>(sizeof(T))}, v.data(), owner);
  if (!writable) py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}
/// A copy of `v` as an (n, 3) float64 array.
py::array_t<double> vec3_copy(const std::vector<Vec3>& v);
/// A 3-vector from any sequence of three numbers.
Vec3 to_vec3(const py::object& o);
/// Indices from any sequence of integers (a list, a NumPy array).
std::vector<Index> to_indices(const py::object& o);
/// A Python object from JSON text (json.loads), and JSON text from a Python object (json.dumps).
py::object json_loads(const std::string& text);
std::string json_dumps(const py::handle& o);

}  // namespace qbond::python
