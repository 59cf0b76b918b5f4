// The bonds as the module sees them: specs, ends, state, tensions and forces.
#include "bonds.hpp"

#include "qbond/analysis/analysis.hpp"
#include "qbond/laws/registry.hpp"

namespace qbond::python {

BondSpec bond_spec(const std::string& law, double stiffness, double damping, const std::string& damping_model,
                   double rest_length, const py::object& shape) {
  BondSpec s;
  const std::optional<Law> l = parse_law(law);
  if (!l) {
    std::string names;
    for (const LawInfo& info : all_laws()) names += (names.empty() ? "" : ", ") + std::string(info.name);
    throw py::value_error("law: must be one of " + names + ", got '" + law + "'");
  }
  s.law = *l;
  if (!(stiffness > 0)) throw py::value_error("stiffness: must be > 0, got " + std::to_string(stiffness));
  if (!(damping >= 0)) throw py::value_error("damping: must be >= 0, got " + std::to_string(damping));
  s.stiffness = stiffness;
  s.damping = damping;
  if (damping_model == "axial") s.damping_model = DampingModel::axial;
  else if (damping_model == "isotropic") s.damping_model = DampingModel::isotropic;
  else throw py::value_error("damping_model: must be one of axial, isotropic, got '" + damping_model + "'");
  s.rest_length = rest_length;
  if (!shape.is_none()) {
    const auto values = shape.cast<std::vector<double>>();
    if (values.size() > s.shape.size())
      throw py::value_error("shape: at most " + std::to_string(s.shape.size()) + " parameters, got " + std::to_string(values.size()));
    std::copy(values.begin(), values.end(), s.shape.begin());
  }
  const std::string bad = invalid_law_shape(s.law, s.shape);
  if (!bad.empty()) throw py::value_error("shape: " + bad);
  return s;
}

py::array_t<std::int64_t> bond_ends(const World& w) {
  const Bonds& bonds = w.state.bonds;
  py::array_t<std::int64_t> a({static_cast<py::ssize_t>(bonds.size()), py::ssize_t{2}});
  auto r = a.mutable_unchecked<2>();
  for (std::size_t b = 0; b < bonds.size(); ++b) {
    r(static_cast<py::ssize_t>(b), 0) = bonds.i[b];
    r(static_cast<py::ssize_t>(b), 1) = bonds.j[b];
  }
  return a;
}

py::array_t<bool> bond_alive(const World& w) {
  const auto& alive = w.state.bonds.alive;
  py::array_t<bool> a(static_cast<py::ssize_t>(alive.size()));
  for (std::size_t b = 0; b < alive.size(); ++b) a.mutable_at(static_cast<py::ssize_t>(b)) = alive[b] != 0;
  return a;
}

py::array_t<double> bond_stiffness(const World& w) {
  const auto& k = w.state.bonds.strength;
  return py::array_t<double>(static_cast<py::ssize_t>(k.size()), k.data());
}

py::array_t<double> bond_rest_length(const World& w) {
  const auto& L = w.state.bonds.rest;
  return py::array_t<double>(static_cast<py::ssize_t>(L.size()), L.data());
}

py::tuple bond_tension_strain(const World& w) {
  std::vector<double> tension, strain;
  qbond::bond_tension_strain(w.model, w.state, tension, strain);
  return py::make_tuple(py::array_t<double>(static_cast<py::ssize_t>(tension.size()), tension.data()),
                        py::array_t<double>(static_cast<py::ssize_t>(strain.size()), strain.data()));
}

py::array_t<double> bond_forces(const World& w) {
  const State& s = w.state;
  const Bonds& bonds = s.bonds;
  std::vector<Vec3> f(w.model.num_quanta(), Vec3::Zero());
  for (std::size_t b = 0; b < bonds.size(); ++b) {
    if (!bonds.alive[b]) continue;
    const Index i = bonds.i[b], j = bonds.j[b];
    const Vec3 fi = bonds.force_on_i(w.model.shapes, b, s.x[j] - s.x[i], s.v[j] - s.v[i], bonds.rest[b]);
    f[i] += fi;
    f[j] -= fi;
  }
  return vec3_copy(f);
}

}  // namespace qbond::python
