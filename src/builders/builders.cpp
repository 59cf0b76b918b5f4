#include "qbond/builders/builders.hpp"

#include <stdexcept>

namespace qbond {

LatticeCell cubic_cell(Shells shells) {
  LatticeCell c{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, 1.0, 1.0, 3};
  if (shells >= Shells::face_diagonal)
    c.offsets.insert(c.offsets.end(), {{1, 1, 0}, {1, -1, 0}, {1, 0, 1}, {1, 0, -1}, {0, 1, 1}, {0, 1, -1}});
  if (shells >= Shells::body_diagonal) c.offsets.insert(c.offsets.end(), {{1, 1, 1}, {1, 1, -1}, {1, -1, 1}, {1, -1, -1}});
  return c;
}

LatticeCell fcc_cell(bool second_shell) {
  LatticeCell c{{{1, 1, 0}, {1, -1, 0}, {1, 0, 1}, {1, 0, -1}, {0, 1, 1}, {0, 1, -1}}, 0.5, 0.25, 3};
  if (second_shell) c.offsets.insert(c.offsets.end(), {{2, 0, 0}, {0, 2, 0}, {0, 0, 2}});
  return c;
}

LatticeCell square_cell(bool diagonals, bool bending) {
  LatticeCell c{{{1, 0, 0}, {0, 1, 0}}, 1.0, 1.0, 2};
  if (diagonals) c.offsets.insert(c.offsets.end(), {{1, 1, 0}, {1, -1, 0}});
  if (bending) c.offsets.insert(c.offsets.end(), {{2, 0, 0}, {0, 2, 0}});
  return c;
}

std::vector<Index> add_cubic_lattice(World& world, const CubicLattice& s, Index body) {
  const int nx = s.size[0], ny = s.size[1], nz = s.size[2];  // named: clang 14 cannot capture bindings
  if (nx < 1 || ny < 1 || nz < 1) throw std::invalid_argument("lattice size must be >= 1 in every axis");
  if (!(s.spacing > 0)) throw std::invalid_argument("lattice spacing must be > 0");
  const LatticeCell cell = cubic_cell(s.shells);
  const double volume = cell.site_volume * s.spacing * s.spacing * s.spacing;
  std::vector<Index> ids;
  ids.reserve(static_cast<std::size_t>(nx) * ny * nz);
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x)
        ids.push_back(world.add_quanta(s.origin + s.spacing * Vec3(x, y, z), s.velocity, s.quanta_mass, body, volume));
  auto id = [&](int x, int y, int z) { return ids[static_cast<std::size_t>((z * ny + y) * nx + x)]; };
  BondSpec spec = s.bond;
  spec.rest_length = -1;
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x)
        for (const auto& o : cell.offsets) {
          const int X = x + o[0], Y = y + o[1], Z = z + o[2];
          if (X < 0 || Y < 0 || Z < 0 || X >= nx || Y >= ny || Z >= nz) continue;
          world.add_bond(id(x, y, z), id(X, Y, Z), spec);
        }
  return ids;
}

std::vector<Index> add_chain(World& world, const Chain& s, Index body) {
  if (s.count < 2) throw std::invalid_argument("a chain needs at least 2 quanta");
  const double segment = (s.end - s.start).norm() / (s.count - 1);
  const double volume = (s.area >= 0 ? s.area : segment * segment) * segment;
  std::vector<Index> ids;
  for (int k = 0; k < s.count; ++k) {
    const double t = static_cast<double>(k) / (s.count - 1);
    ids.push_back(world.add_quanta(s.start + t * (s.end - s.start), s.velocity, s.quanta_mass, body, volume));
  }
  BondSpec spec = s.bond;
  spec.rest_length = -1;
  for (int k = 0; k + 1 < s.count; ++k) world.add_bond(ids[k], ids[k + 1], spec);
  return ids;
}

}  // namespace qbond

namespace qbond {

std::vector<Index> add_square_lattice(World& world, const SquareLattice& s, Index body) {
  const auto [nx, ny] = s.size;
  if (nx < 1 || ny < 1) throw std::invalid_argument("lattice size must be >= 1 in every axis");
  if (!(s.spacing > 0)) throw std::invalid_argument("lattice spacing must be > 0");
  const LatticeCell cell = square_cell(s.diagonals, s.bending);
  const double volume = cell.site_volume * s.spacing * s.spacing * (s.thickness >= 0 ? s.thickness : s.spacing);
  std::vector<Index> ids;
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x)
      ids.push_back(world.add_quanta(s.spacing * Vec3(x, y, 0), Vec3::Zero(), s.quanta_mass, body, volume));
  BondSpec spec = s.bond;
  spec.rest_length = -1;
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x)
      for (const auto& o : cell.offsets) {
        const int X = x + o[0], Y = y + o[1];
        if (X < 0 || Y < 0 || X >= nx || Y >= ny) continue;
        world.add_bond(ids[static_cast<std::size_t>(y * nx + x)], ids[static_cast<std::size_t>(Y * nx + X)], spec);
      }
  return ids;
}

std::vector<Index> add_fcc_lattice(World& world, const FccLattice& s, Index body) {
  const auto [cx, cy, cz] = s.cells;
  if (cx < 1 || cy < 1 || cz < 1) throw std::invalid_argument("fcc cells must be >= 1 in every axis");
  if (!(s.spacing > 0)) throw std::invalid_argument("lattice spacing must be > 0");
  // FCC sites on the half-spacing grid: points (i, j, k) with i + j + k even, 0 <= i <= 2 cx.
  const int nx = 2 * cx + 1, ny = 2 * cy + 1, nz = 2 * cz + 1;
  std::vector<std::int64_t> site(static_cast<std::size_t>(nx) * ny * nz, -1);
  auto at = [&](int i, int j, int k) -> std::int64_t& { return site[(static_cast<std::size_t>(k) * ny + j) * nx + i]; };
  const LatticeCell cell = fcc_cell(s.second_shell);
  const double volume = cell.site_volume * s.spacing * s.spacing * s.spacing;
  std::vector<Index> ids;
  const double h = cell.unit * s.spacing;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        if ((i + j + k) % 2 == 0) {
          at(i, j, k) = static_cast<std::int64_t>(ids.size());
          ids.push_back(world.add_quanta(h * Vec3(i, j, k), Vec3::Zero(), s.quanta_mass, body, volume));
        }
  BondSpec spec = s.bond;
  spec.rest_length = -1;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (at(i, j, k) < 0) continue;
        for (const auto& o : cell.offsets) {
          const int I = i + o[0], J = j + o[1], K = k + o[2];
          if (I < 0 || J < 0 || K < 0 || I >= nx || J >= ny || K >= nz) continue;
          world.add_bond(ids[static_cast<std::size_t>(at(i, j, k))], ids[static_cast<std::size_t>(at(I, J, K))], spec);
        }
      }
  return ids;
}

void place_body(World& world, const std::vector<Index>& ids, const Placement& p) {
  if (ids.empty()) return;
  State& s = world.state;
  const Mat3 R = Eigen::AngleAxisd(p.angle, p.axis.normalized()).toRotationMatrix();
  double mass = 0;
  Vec3 cm = Vec3::Zero();
  for (Index i : ids) {
    s.x[i] = R * s.x[i] + p.origin;
    mass += world.model.mass[i];
    cm += world.model.mass[i] * s.x[i];
  }
  cm /= mass;
  for (Index i : ids) s.v[i] = p.velocity + p.angular_velocity.cross(s.x[i] - cm);
}

}  // namespace qbond
