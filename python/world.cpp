// World: quanta and bonds, built one by one or with the library's builders.
#include "bindings.hpp"
#include "bonds.hpp"

#include "qbond/builders/builders.hpp"
#include "qbond/model/ordering.hpp"

namespace qbond::python {

Shells parse_shells(const std::string& s) {
  if (s == "nearest") return Shells::nearest;
  if (s == "face_diagonal") return Shells::face_diagonal;
  if (s == "body_diagonal") return Shells::body_diagonal;
  throw py::value_error("shells: must be one of nearest, face_diagonal, body_diagonal, got '" + s + "'");
}

void bind_world(py::module_& m) {
  py::class_<World> world(m, "World", "Quanta (point masses) and the bonds between them, with gravity, loads and anchors.");
  world.def(py::init<>(), "An empty world.")
      .def_property_readonly("num_quanta", &World::num_quanta, "Number of quanta.")
      .def_property_readonly("num_bonds", &World::num_bonds, "Number of bonds, broken ones included.")
      .def_property(
          "gravity", [](const World& w) { return py::make_tuple(w.model.gravity.x(), w.model.gravity.y(), w.model.gravity.z()); },
          [](World& w, const py::object& g) { w.model.gravity = to_vec3(g); }, "Gravitational acceleration [m/s²], (gx, gy, gz).")
      .def("add_body", &World::add_body, py::arg("name"), "Adds a named body; returns its id.")
      .def(
          "add_quanta",
          [](World& w, const py::object& x, const py::object& v, double mass, Index body, double volume) {
            if (!(mass >= 0)) throw py::value_error("mass: must be >= 0, got " + std::to_string(mass));
            if (!(volume >= 0)) throw py::value_error("volume: must be >= 0, got " + std::to_string(volume));
            return w.add_quanta(to_vec3(x), to_vec3(v), mass, body, volume);
          },
          py::arg("x"), py::arg("v") = py::make_tuple(0, 0, 0), py::arg("mass") = 1e-3, py::arg("body") = 0,
          py::arg("volume") = 0.0,
          "Adds a quanta at x [m] with velocity v [m/s] and mass [kg] (0: kinematic, held where it is); returns its index.")
      .def(
          "add_bond",
          [](World& w, Index i, Index j, double stiffness, const std::string& law, double damping,
             const std::string& damping_model, double rest_length, const py::object& shape) {
            check_quanta(w, {i, j});
            if (i == j) throw py::value_error("a bond needs two different quanta, got " + std::to_string(i) + " twice");
            return w.add_bond(i, j, bond_spec(law, stiffness, damping, damping_model, rest_length, shape));
          },
          py::arg("i"), py::arg("j"), py::arg("stiffness"), py::arg("law") = "linear", py::arg("damping") = 0.0,
          py::arg("damping_model") = "axial", py::arg("rest_length") = -1.0, py::arg("shape") = py::none(),
          "Bonds quanta i and j with a law (linear, inverse, morse, fene, cohesive) of strength `stiffness`, "
          "damping D [N·s/m]; rest_length < 0: their current distance. Returns the bond's index.")
      .def(
          "add_cubic_lattice",
          [](World& w, std::array<int, 3> size, double spacing, double quanta_mass, double stiffness, double damping,
             const std::string& law, const std::string& shells, const py::object& origin, const py::object& velocity, Index body) {
            for (int s : size)
              if (s < 1) throw py::value_error("size: every count must be >= 1");
            if (!(spacing > 0)) throw py::value_error("spacing: must be > 0, got " + std::to_string(spacing));
            if (!(quanta_mass > 0)) throw py::value_error("quanta_mass: must be > 0, got " + std::to_string(quanta_mass));
            CubicLattice c;
            c.size = size;
            c.spacing = spacing;
            c.quanta_mass = quanta_mass;
            c.origin = to_vec3(origin);
            c.velocity = to_vec3(velocity);
            c.shells = parse_shells(shells);
            c.bond = bond_spec(law, stiffness, damping, "axial", -1, py::none());
            return ids_array(add_cubic_lattice(w, c, body));
          },
          py::arg("size"), py::arg("spacing"), py::arg("quanta_mass"), py::arg("stiffness"), py::arg("damping") = 0.0,
          py::arg("law") = "linear", py::arg("shells") = "face_diagonal", py::arg("origin") = py::make_tuple(0, 0, 0),
          py::arg("velocity") = py::make_tuple(0, 0, 0), py::arg("body") = 0,
          "Adds a simple-cubic block of size[0]×size[1]×size[2] quanta `spacing` apart (x fastest), bonded to the "
          "neighbour shells named; returns the new quanta's indices.")
      .def(
          "add_chain",
          [](World& w, int count, const py::object& start, const py::object& end, double quanta_mass, double stiffness,
             double damping, const std::string& law, const py::object& velocity, Index body) {
            if (count < 2) throw py::value_error("count: must be >= 2, got " + std::to_string(count));
            if (!(quanta_mass > 0)) throw py::value_error("quanta_mass: must be > 0, got " + std::to_string(quanta_mass));
            Chain c;
            c.count = count;
            c.start = to_vec3(start);
            c.end = to_vec3(end);
            c.quanta_mass = quanta_mass;
            c.velocity = to_vec3(velocity);
            c.bond = bond_spec(law, stiffness, damping, "axial", -1, py::none());
            return ids_array(add_chain(w, c, body));
          },
          py::arg("count"), py::arg("start"), py::arg("end"), py::arg("quanta_mass"), py::arg("stiffness"),
          py::arg("damping") = 0.0, py::arg("law") = "linear", py::arg("velocity") = py::make_tuple(0, 0, 0),
          py::arg("body") = 0, "Adds a straight chain of `count` quanta from start to end, neighbours bonded; returns their indices.")
      .def(
          "add_square_lattice",
          [](World& w, std::array<int, 2> size, double spacing, double quanta_mass, double stiffness, double damping,
             bool diagonals, bool bending, Index body) {
            for (int s : size)
              if (s < 1) throw py::value_error("size: every count must be >= 1");
            if (!(spacing > 0)) throw py::value_error("spacing: must be > 0, got " + std::to_string(spacing));
            if (!(quanta_mass > 0)) throw py::value_error("quanta_mass: must be > 0, got " + std::to_string(quanta_mass));
            SquareLattice s;
            s.size = size;
            s.spacing = spacing;
            s.quanta_mass = quanta_mass;
            s.diagonals = diagonals;
            s.bending = bending;
            s.bond = bond_spec("linear", stiffness, damping, "axial", -1, py::none());
            return ids_array(add_square_lattice(w, s, body));
          },
          py::arg("size"), py::arg("spacing"), py::arg("quanta_mass"), py::arg("stiffness"), py::arg("damping") = 0.0,
          py::arg("diagonals") = true, py::arg("bending") = false, py::arg("body") = 0,
          "Adds a square sheet of size[0]×size[1] quanta in the xy plane (x fastest); returns their indices.")
      .def(
          "select_box",
          [](const World& w, const py::object& lo, const py::object& hi) {
            const Vec3 a = to_vec3(lo), b = to_vec3(hi);
            std::vector<Index> ids;
            for (Index i = 0; i < w.num_quanta(); ++i) {
              const Vec3& x = w.state.x[i];
              if ((x.array() >= a.array()).all() && (x.array() <= b.array()).all()) ids.push_back(i);
            }
            return ids_array(ids);
          },
          py::arg("lo"), py::arg("hi"), "Indices of the quanta inside the box [lo, hi] (bounds included).")
      .def(
          "anchor",
          [](World& w, const py::object& ids) {
            std::vector<Index> q = to_indices(ids);
            check_quanta(w, q);
            w.prescribe(std::move(q), Motion{});
          },
          py::arg("quanta"), "Holds the quanta fixed where they are (kinematic, inverse mass 0).")
      .def(
          "add_load",
          [](World& w, const py::object& ids, const py::object& force) {
            std::vector<Index> q = to_indices(ids);
            check_quanta(w, q);
            if (q.empty()) throw py::value_error("a load needs at least one quanta");
            w.add_load(std::move(q), to_vec3(force));
          },
          py::arg("quanta"), py::arg("force"), "Adds a constant total force [N] spread evenly over the quanta.")
      .def(
          "renumber_for_locality", [](World& w) { renumber(w, locality_order(w)); },
          "Renumbers quanta and bonds for memory locality, as scene loading does (quanta_id keeps the creation order).")
      .def_property_readonly("positions", [](const World& w) { return vec3_copy(w.state.x); }, "(n, 3) positions [m] (a copy).")
      .def_property_readonly("velocities", [](const World& w) { return vec3_copy(w.state.v); }, "(n, 3) velocities [m/s] (a copy).")
      .def_property_readonly(
          "masses", [](const World& w) { return py::array_t<double>(static_cast<py::ssize_t>(w.num_quanta()), w.model.mass.data()); },
          "(n,) masses [kg] (a copy).")
      .def_property_readonly("bond_ends", &bond_ends, "(nb, 2) end quanta of every bond (a copy).")
      .def("__repr__", [](const World& w) {
        return "<qbond.World " + std::to_string(w.num_quanta()) + " quanta, " + std::to_string(w.num_bonds()) + " bonds>";
      });
  bind_world_geometry(world);
  bind_world_motion(world);
}

}  // namespace qbond::python
