#include "qbond/builders.hpp"

#include <stdexcept>

namespace qbond {

std::vector<Index> add_cubic_lattice(World& world, const CubicLattice& s, Index body) {
  const auto [nx, ny, nz] = s.size;
  if (nx < 1 || ny < 1 || nz < 1) throw std::invalid_argument("lattice size must be >= 1 in every axis");
  if (!(s.spacing > 0)) throw std::invalid_argument("lattice spacing must be > 0");
  std::vector<Index> ids;
  ids.reserve(static_cast<std::size_t>(nx) * ny * nz);
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x)
        ids.push_back(world.add_quanta(s.origin + s.spacing * Vec3(x, y, z), s.velocity, s.quanta_mass, body));
  auto id = [&](int x, int y, int z) { return ids[static_cast<std::size_t>((z * ny + y) * nx + x)]; };
  // Half of each shell's offsets, so every pair is bonded once.
  std::vector<std::array<int, 3>> offsets = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  if (s.shells >= Shells::face_diagonal)
    offsets.insert(offsets.end(), {{1, 1, 0}, {1, -1, 0}, {1, 0, 1}, {1, 0, -1}, {0, 1, 1}, {0, 1, -1}});
  if (s.shells >= Shells::body_diagonal)
    offsets.insert(offsets.end(), {{1, 1, 1}, {1, 1, -1}, {1, -1, 1}, {1, -1, -1}});
  BondSpec spec = s.bond;
  spec.rest_length = -1;
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x)
        for (const auto& o : offsets) {
          const int X = x + o[0], Y = y + o[1], Z = z + o[2];
          if (X < 0 || Y < 0 || Z < 0 || X >= nx || Y >= ny || Z >= nz) continue;
          world.add_bond(id(x, y, z), id(X, Y, Z), spec);
        }
  return ids;
}

std::vector<Index> add_chain(World& world, const Chain& s, Index body) {
  if (s.count < 2) throw std::invalid_argument("a chain needs at least 2 quanta");
  std::vector<Index> ids;
  for (int k = 0; k < s.count; ++k) {
    const double t = static_cast<double>(k) / (s.count - 1);
    ids.push_back(world.add_quanta(s.start + t * (s.end - s.start), s.velocity, s.quanta_mass, body));
  }
  BondSpec spec = s.bond;
  spec.rest_length = -1;
  for (int k = 0; k + 1 < s.count; ++k) world.add_bond(ids[k], ids[k + 1], spec);
  return ids;
}

}  // namespace qbond
