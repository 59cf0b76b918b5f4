#pragma once
// One `bodies` entry as its type's builder reads it (the rows of Builder::body_readers): the
// entry's JSON and path, its part of the resolved scene, the world, the body's id and material,
// and the checks and conversions the body types share.
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "io/scene/builder.hpp"
#include "qbond/builders/builders.hpp"

namespace qbond::scene_detail {

struct BodyEntry {
  Builder& builder;
  const json& j;
  const std::string& path;
  json& res;
  World& w;
  Index id;
  const Material* mat;  // null for a type that takes no material
  const std::string& type;

  // The value of a required key.
  const json& req(const char* key) const;
  std::string at(const char* key) const { return path + "." + key; }
  // `size` as `dims` counts ≥ 1 (the others 1) and their product; checked before anything is made,
  // so that a typo does not allocate a billion quanta.
  std::pair<std::array<int, 3>, double> sizes(std::size_t dims) const;
  // Each quanta's mass for `count` quanta: `calibrated` (from the material's density) when > 0,
  // else from `quanta_mass` or `total_mass`, exactly one of which the entry gives.
  double mass_of(double count, double calibrated) const;
  // A lattice's bond: the material's, with its stiffness from the modulus when the material has one.
  BondSpec lattice_bond(const LatticeCell& cell, double a, double thickness) const;
  // A lattice quanta's mass from the material's density (0 without one).
  double lattice_mass(const LatticeCell& cell, double a, double thickness) const;
  // Refuses more than kMaxQuanta quanta.
  void too_many(double count) const;
  // Plans a lattice's memory: one bond per offset of its cell for each site (fewer at the faces).
  void plan_lattice(double count, const LatticeCell& c) const;
  // A square cell is a sheet of some thickness (default: the spacing), which turns its stiffness
  // per length into a modulus and its area per quanta into a volume.
  double thickness(double a, bool square) const;

  // The builders of the types bodies.cpp makes itself.
  std::vector<Index> lattice() const;  // `lattice` and `sheet`
  std::vector<Index> chain() const;
  std::vector<Index> quanta() const;
  // file_bodies.cpp: the types read from other programs' files
  std::vector<Index> tet_mesh() const;
  std::vector<Index> csv() const;
  std::vector<Index> lammps() const;
};

}  // namespace qbond::scene_detail
