#pragma once
/// LAMMPS data files (the `read_data`/`write_data` format): atoms, masses, velocities and bonds,
/// so that a structure moves between LAMMPS and qbond (docs/scene-format.md, `lammps` bodies;
/// `qbond export --lammps`). Numbers are taken as SI (LAMMPS `units si`).
#include <array>
#include <iosfwd>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "qbond/core/math.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

/// The columns of a data file's Atoms section (LAMMPS `atom_style`): atomic (id type x y z),
/// bond and molecular (id molecule type x y z), full (id molecule type q x y z); each line may
/// end with three image flags.
enum class AtomStyle : std::uint8_t { atomic, bond, molecular, full };

/// What a LAMMPS data file holds that qbond uses, atoms sorted by their ID.
struct LammpsData {
  std::array<double, 6> box{};  ///< xlo xhi ylo yhi zlo zhi [m]
  std::array<double, 3> tilt{};  ///< xy xz yz of a triclinic box [m] (0: orthogonal)
  std::vector<long long> atom_id{};
  std::vector<int> atom_type{};  ///< 1-based
  std::vector<Vec3> x{};         ///< [m], unwrapped by the image flags
  std::vector<Vec3> v{};         ///< [m/s]; zero without a Velocities section
  std::vector<double> type_mass{};  ///< [kg] per atom type (index type − 1)
  int bond_types = 0;
  std::vector<int> bond_type{};                     ///< 1-based
  std::vector<std::pair<Index, Index>> bond_ends{};  ///< rows of the atom arrays
  std::vector<std::string> ignored{};  ///< the sections present but not read (Angles, Pair Coeffs, …)
};

/// Reads a data file. `style` gives the Atoms columns; without it (nullptr) they come from the
/// comment after the Atoms keyword (`Atoms # full`, as write_data puts it), else atom_style bond.
/// Masses is required; Velocities is optional; Angles, Dihedrals, Impropers and the coefficient
/// sections are skipped (listed in `ignored`). Throws std::runtime_error "NAME:LINE: rule".
LammpsData parse_lammps_data(std::string_view text, const std::string& name, const AtomStyle* style = nullptr);

/// Writes the world as a data file of atom_style bond: one atom per quanta (ID = its user id + 1,
/// molecule = its body + 1, one atom type per distinct mass, in order of first appearance), its
/// velocity, and one bond per alive bond, one bond type per distinct law and parameters, which the
/// header's comments describe. Positions, masses and velocities are written with 17 significant
/// digits, so that reading the file back gives the same numbers bit for bit. The box is the
/// quanta's bounding box widened by 1 % of its largest edge (at least 1 mm).
void write_lammps_data(std::ostream& out, const World& world, const std::string& title);

/// The bond types write_lammps_data writes: for each alive bond, its type (1-based), and the
/// number of types.
std::pair<std::vector<int>, int> lammps_bond_types(const World& world);

}  // namespace qbond
