#include "qbond/samples.hpp"

#include <stdexcept>

#include "qbond/builders.hpp"

namespace qbond {
namespace {

// The paper's Figure 10: a heavy cube hanging on an elastic rope, set swinging.
SampleScene pendulum() {
  SampleScene s;
  World& w = s.world;
  w.model.gravity = Vec3(0, 0, -9.81);
  const Vec3 pivot(0, 0, 1.2);
  const Index rope_body = w.add_body("rope");
  const Index cube_body = w.add_body("cube");
  Chain rope;
  rope.count = 11;
  rope.start = pivot;
  rope.end = pivot - Vec3(0, 0, 1.0);
  rope.quanta_mass = 0.01;
  rope.bond = {.law = Law::linear, .stiffness = 2.0e4, .damping = 2.0};
  const std::vector<Index> r = add_chain(w, rope, rope_body);
  CubicLattice cube;
  cube.size = {3, 3, 3};
  cube.spacing = 0.05;
  cube.quanta_mass = 0.2;
  cube.origin = rope.end - Vec3(0.05, 0.05, 0.1 + 0.1);
  cube.shells = Shells::face_diagonal;
  cube.bond = {.law = Law::linear, .stiffness = 5.0e4, .damping = 5.0};
  const std::vector<Index> c = add_cubic_lattice(w, cube, cube_body);
  // The rope's end holds the middle of the cube's top face (quanta (1,1,2)).
  w.add_bond(r.back(), c[(2 * 3 + 1) * 3 + 1], rope.bond);
  w.prescribe({r.front()}, Motion{});
  // Set swinging: a rigid rotation about the pivot at 1.5 rad/s around y.
  const Vec3 omega(0, 1.5, 0);
  for (std::size_t i = 0; i < w.num_quanta(); ++i)
    if (!w.model.is_kinematic(static_cast<Index>(i))) w.state.v[i] = omega.cross(w.state.x[i] - pivot);
  s.timestep = 1e-3;
  s.steps = 5000;
  return s;
}

}  // namespace

SampleScene canonical_lattice(int n) {
  SampleScene s;
  World& w = s.world;
  w.model.gravity = Vec3(0, 0, -9.81);
  CubicLattice lat;
  lat.size = {n, n, n};
  lat.spacing = 0.01;
  lat.quanta_mass = 1e-3;
  lat.shells = Shells::face_diagonal;
  lat.bond = {.law = Law::linear, .stiffness = 1000.0, .damping = 0.01};
  const Index body = w.add_body("lattice");
  const std::vector<Index> ids = add_cubic_lattice(w, lat, body);
  std::vector<Index> face;
  for (Index i : ids)
    if (w.state.x[i].x() == 0.0) face.push_back(i);
  w.prescribe(face, Motion{});
  s.timestep = 1e-4;
  s.steps = 1000;
  return s;
}

const std::vector<Sample>& samples() {
  static const std::vector<Sample> all = {
      {"pendulum", "the paper's Figure 10: a heavy cube on an elastic rope, set swinging", pendulum},
      {"lattice10", "canonical 10x10x10 lattice, anchored at x = 0, sagging under gravity",
       [] { return canonical_lattice(10); }},
  };
  return all;
}

const Sample& find_sample(const std::string& name) {
  std::string names;
  for (const Sample& s : samples()) {
    if (s.name == name) return s;
    names += (names.empty() ? "" : ", ") + s.name;
  }
  throw std::invalid_argument("unknown built-in scene '" + name + "' (built-in scenes: " + names + ")");
}

}  // namespace qbond
