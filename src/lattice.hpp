#pragma once
// Neighbour shells of the simple-cubic lattice, shared by add_cubic_lattice and
// add_mesh_lattice so that a voxelised mesh is bonded exactly as a cubic block is.
#include <array>
#include <vector>

#include "qbond/builders.hpp"

namespace qbond {

// Half of each shell's grid offsets (one of every ± pair), so that bonding each site to
// site + offset bonds every pair once; in the order both builders make their bonds.
inline std::vector<std::array<int, 3>> half_shell_offsets(Shells shells) {
  std::vector<std::array<int, 3>> offsets = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  if (shells >= Shells::face_diagonal)
    offsets.insert(offsets.end(), {{1, 1, 0}, {1, -1, 0}, {1, 0, 1}, {1, 0, -1}, {0, 1, 1}, {0, 1, -1}});
  if (shells >= Shells::body_diagonal)
    offsets.insert(offsets.end(), {{1, 1, 1}, {1, 1, -1}, {1, -1, 1}, {1, -1, -1}});
  return offsets;
}

}  // namespace qbond
