// World's builders of irregular bodies (docs/geometry.md, docs/gases.md): FCC lattices, point
// packings, closed OBJ/STL meshes voxelised, gases; and the placement of a built body. Masses and
// volumes are set as scene loading sets them, so a world built here steps to the scene's bits.
#include <cmath>

#include "bindings.hpp"
#include "bonds.hpp"
#include "qbond/builders/gas.hpp"
#include "qbond/builders/packing.hpp"

namespace qbond::python {

namespace {

Shells shells_of(const std::string& s) {
  if (s == "nearest") return Shells::nearest;
  if (s == "face_diagonal") return Shells::face_diagonal;
  if (s == "body_diagonal") return Shells::body_diagonal;
  throw py::value_error("shells: must be one of nearest, face_diagonal, body_diagonal, got '" + s + "'");
}

Isolated isolated_of(const std::string& s) {
  if (s == "drop") return Isolated::drop;
  if (s == "keep") return Isolated::keep;
  if (s == "error") return Isolated::error;
  throw py::value_error("isolated: must be one of drop, keep, error, got '" + s + "'");
}

void positive(double v, const char* name) {
  if (!(v > 0) || !std::isfinite(v))
    throw py::value_error(std::string(name) + ": must be > 0, got " + std::to_string(v));
}

void set_volumes(World& w, const std::vector<Index>& ids, double volume) {
  for (Index i : ids) w.model.volume[i] = volume;
}

}  // namespace

void bind_world_geometry(py::class_<World>& world) {
  world
      .def(
          "add_fcc_lattice",
          [](World& w, std::array<int, 3> cells, double spacing, double quanta_mass, double stiffness,
             double damping, const std::string& law, bool second_shell, Index body) {
            for (int c : cells)
              if (c < 1) throw py::value_error("cells: every count must be >= 1");
            positive(spacing, "spacing");
            positive(quanta_mass, "quanta_mass");
            FccLattice f;
            f.cells = cells;
            f.spacing = spacing;
            f.quanta_mass = quanta_mass;
            f.second_shell = second_shell;
            f.bond = bond_spec(law, stiffness, damping, "axial", -1, py::none());
            return ids_array(add_fcc_lattice(w, f, body));
          },
          py::arg("cells"), py::arg("spacing"), py::arg("quanta_mass"), py::arg("stiffness"),
          py::arg("damping") = 0.0, py::arg("law") = "linear", py::arg("second_shell") = false,
          py::arg("body") = 0,
          "Adds a face-centred cubic block of cells[0]×cells[1]×cells[2] cubic cells of side `spacing` [m] "
          "at the "
          "origin, bonded to the 12 nearest neighbours (and the 6 second ones with second_shell); returns "
          "its quanta.")
      .def(
          "add_point_packing",
          [](World& w, const py::object& size, double min_distance, double bond_radius, double quanta_mass,
             double stiffness, double damping, const std::string& law, const std::string& points,
             std::size_t count, std::uint64_t seed, const std::string& isolated, Index body) {
            PointPacking p;
            if (points == "poisson")
              p.kind = PointPacking::poisson;
            else if (points == "random")
              p.kind = PointPacking::random;
            else
              throw py::value_error("points: must be poisson or random, got '" + points + "'");
            p.size = to_vec3(size);
            p.min_distance = min_distance;
            p.count = count;
            p.bond_radius = bond_radius;
            positive(quanta_mass, "quanta_mass");
            p.quanta_mass = quanta_mass;
            p.bond = bond_spec(law, stiffness, damping, "axial", -1, py::none());
            p.seed = seed;
            p.isolated = isolated_of(isolated);
            const std::vector<Index> ids =
                add_point_packing(w, p, body);  // std::invalid_argument → ValueError
            if (ids.empty())
              throw py::value_error("bond_radius: no two points lie within " + std::to_string(bond_radius) +
                                    " m: every point is isolated");
            // Each point stands for the box's volume over the points (a flat packing: a layer one
            // mean spacing thick), as a scene's packing body.
            const double per = p.size.x() * p.size.y() / static_cast<double>(ids.size());
            set_volumes(w, ids, p.size.z() > 0 ? per * p.size.z() : per * std::sqrt(per));
            return ids_array(ids);
          },
          py::arg("size"), py::arg("min_distance"), py::arg("bond_radius"), py::arg("quanta_mass"),
          py::arg("stiffness"), py::arg("damping") = 0.0, py::arg("law") = "linear",
          py::arg("points") = "poisson", py::arg("count") = 0, py::arg("seed") = 1,
          py::arg("isolated") = "drop", py::arg("body") = 0,
          "Adds points in the box [0, size] (size z = 0: a flat packing), Poisson-disk (no two closer than "
          "min_distance; count caps them, 0: fill the box) or `count` random ones, each bonded to every "
          "other at most "
          "bond_radius away. isolated: drop, keep or error for points left without a bond. Same seed, same "
          "points. "
          "Returns its quanta.")
      .def(
          "add_mesh",
          [](World& w, const std::string& file, double spacing, double quanta_mass, double stiffness,
             double damping, const std::string& law, const std::string& shells, double scale,
             const std::string& isolated, Index body) {
            positive(spacing, "spacing");
            positive(quanta_mass, "quanta_mass");
            positive(scale, "scale");
            MeshLattice m;
            m.mesh = read_mesh(file);  // std::runtime_error "FILE:LINE: rule" → RuntimeError
            check_closed(m.mesh, file);
            m.scale = scale;
            m.spacing = spacing;
            m.shells = shells_of(shells);
            m.quanta_mass = quanta_mass;
            m.bond = bond_spec(law, stiffness, damping, "axial", -1, py::none());
            m.isolated = isolated_of(isolated);
            const std::vector<Index> ids = add_mesh_lattice(w, m, body);
            set_volumes(w, ids, spacing * spacing * spacing);
            return ids_array(ids);
          },
          py::arg("file"), py::arg("spacing"), py::arg("quanta_mass"), py::arg("stiffness"),
          py::arg("damping") = 0.0, py::arg("law") = "linear", py::arg("shells") = "face_diagonal",
          py::arg("scale") = 1.0, py::arg("isolated") = "drop", py::arg("body") = 0,
          "Fills a closed OBJ or STL mesh (its coordinates × scale, in metres) with a simple-cubic lattice "
          "of "
          "`spacing`: the grid's cell centres inside the mesh, bonded to the neighbour shells named. Raises "
          "RuntimeError 'FILE:LINE: rule' for a malformed or open mesh. Returns its quanta.")
      .def(
          "add_gas",
          [](World& w, const py::object& size, std::size_t count, double min_distance, double quanta_mass,
             double kT, const std::string& speeds, std::uint64_t seed, Index body) {
            Gas g;
            g.size = to_vec3(size);
            g.count = count;
            g.min_distance = min_distance;
            g.quanta_mass = quanta_mass;
            g.kT = kT;
            if (speeds == "maxwell")
              g.speeds = Gas::Speeds::maxwell;
            else if (speeds == "equal")
              g.speeds = Gas::Speeds::equal;
            else
              throw py::value_error("speeds: must be maxwell or equal, got '" + speeds + "'");
            g.seed = seed;
            return ids_array(add_gas(w, g, body));  // std::invalid_argument → ValueError
          },
          py::arg("size"), py::arg("count"), py::arg("min_distance"), py::arg("quanta_mass"), py::arg("kT"),
          py::arg("speeds") = "maxwell", py::arg("seed") = 1, py::arg("body") = 0,
          "Adds `count` unbonded quanta at random positions in the box [0, size], no two closer than "
          "min_distance, "
          "with thermal velocities (maxwell or equal speeds): zero total momentum, kinetic energy exactly "
          "3/2 count kT [J]. Returns its quanta.")
      .def(
          "place",
          [](World& w, const py::object& ids, const py::object& origin, const py::object& axis, double angle,
             const py::object& velocity, const py::object& angular_velocity) {
            std::vector<Index> q = to_indices(ids);
            check_quanta(w, q);
            Placement p;
            p.origin = to_vec3(origin);
            p.axis = to_vec3(axis);
            if (!(p.axis.norm() > 0)) throw py::value_error("axis: must be non-zero");
            p.axis.normalize();
            p.angle = angle;
            p.velocity = to_vec3(velocity);
            p.angular_velocity = to_vec3(angular_velocity);
            place_body(w, q, p);
          },
          py::arg("quanta"), py::arg("origin") = py::make_tuple(0, 0, 0),
          py::arg("axis") = py::make_tuple(0, 0, 1), py::arg("angle") = 0.0,
          py::arg("velocity") = py::make_tuple(0, 0, 0),
          py::arg("angular_velocity") = py::make_tuple(0, 0, 0),
          "Places a body built at the origin as a scene's placement keys do: rotates the quanta by `angle` "
          "[rad] "
          "about `axis`, translates them by `origin` [m], and sets the rigid velocity field v = velocity + ω "
          "× "
          "(x − x_cm).");
}

}  // namespace qbond::python
