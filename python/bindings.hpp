#pragma once
// The pieces of the Python module, one per file; module.cpp calls each bind_* in turn.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <vector>

#include "qbond/core/math.hpp"
#include "qbond/model/world.hpp"

namespace qbond::python {

namespace py = pybind11;

// errors.cpp: the module's exceptions and the translation of the library's.
void bind_errors(py::module_& m);
// scene.cpp: Scene (files, JSON text, dicts) and checkpoints.
void bind_scene(py::module_& m);
// world.cpp: World and its builders.
void bind_world(py::module_& m);
// geometry.cpp: World's builders of irregular bodies (FCC lattices, point packings, meshes) and placement.
void bind_world_geometry(py::class_<World>& world);
// motion.cpp: World's prescribed motions (fixed, translate, rotate, keyframes).
void bind_world_motion(py::class_<World>& world);
/// The motion the Python arguments describe (motion.cpp); throws ValueError naming a bad one.
Motion make_motion(const std::string& type, const py::object& velocity, const py::object& axis, const py::object& center,
                   double rate, const py::object& keyframes, const std::string& interpolation);
/// Prescribes `motion` to the quanta, after checking they exist and follow no motion yet.
void prescribe_checked(World& w, std::vector<Index> quanta, Motion motion);
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
/// An (n,) int64 array of quanta indices (a copy).
py::array_t<std::int64_t> ids_array(const std::vector<Index>& ids);
/// Raises IndexError unless every index names a quanta of `w`.
void check_quanta(const World& w, const std::vector<Index>& ids);
/// A Python object from JSON text (json.loads), and JSON text from a Python object (json.dumps).
py::object json_loads(const std::string& text);
std::string json_dumps(const py::handle& o);

}  // namespace qbond::python
