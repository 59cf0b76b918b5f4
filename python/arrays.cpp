// NumPy arrays of the library's vectors: views of its storage where the layout allows (Vec3 is
// three contiguous doubles, so a std::vector<Vec3> is an (n, 3) C-ordered array), copies elsewhere.
#include "bindings.hpp"

namespace qbond::python {

static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");

py::array_t<double> vec3_view(std::vector<Vec3>& v, py::handle owner, bool writable) {
  const auto n = static_cast<py::ssize_t>(v.size());
  py::array_t<double> a({n, py::ssize_t{3}}, {static_cast<py::ssize_t>(sizeof(Vec3)), static_cast<py::ssize_t>(sizeof(double))},
                        v.empty() ? nullptr : v.data()->data(), owner);
  if (!writable) py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

py::array_t<double> vec3_copy(const std::vector<Vec3>& v) {
  py::array_t<double> a({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  auto r = a.mutable_unchecked<2>();
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int k = 0; k < 3; ++k) r(static_cast<py::ssize_t>(i), k) = v[i][k];
  return a;
}

Vec3 to_vec3(const py::object& o) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(o);
  if (!a || a.ndim() != 1 || a.shape(0) != 3) throw py::value_error("expected three numbers, got " + py::repr(o).cast<std::string>());
  return {a.at(0), a.at(1), a.at(2)};
}

std::vector<Index> to_indices(const py::object& o) {
  const auto a = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(o);
  if (!a || a.ndim() != 1) throw py::value_error("expected a sequence of quanta indices");
  std::vector<Index> out;
  out.reserve(static_cast<std::size_t>(a.shape(0)));
  for (py::ssize_t k = 0; k < a.shape(0); ++k) {
    if (a.at(k) < 0) throw py::value_error("quanta index must be >= 0, got " + std::to_string(a.at(k)));
    out.push_back(static_cast<Index>(a.at(k)));
  }
  return out;
}

py::object json_loads(const std::string& text) { return py::module_::import("json").attr("loads")(text); }

std::string json_dumps(const py::handle& o) { return py::module_::import("json").attr("dumps")(o).cast<std::string>(); }

py::array_t<std::int64_t> ids_array(const std::vector<Index>& ids) {
  py::array_t<std::int64_t> a(static_cast<py::ssize_t>(ids.size()));
  for (std::size_t k = 0; k < ids.size(); ++k) a.mutable_at(static_cast<py::ssize_t>(k)) = ids[k];
  return a;
}

void check_quanta(const World& w, const std::vector<Index>& ids) {
  for (Index i : ids)
    if (i >= w.num_quanta())
      throw py::index_error("quanta " + std::to_string(i) + " does not exist (the world has " + std::to_string(w.num_quanta()) + ")");
}

}  // namespace qbond::python
