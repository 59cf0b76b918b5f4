#include "qbond/builders/voxelise.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "builders/bonded_points.hpp"

namespace qbond {

MeshGrid mesh_grid(const MeshLattice& s) {
  if (!(s.spacing > 0) || !std::isfinite(s.spacing))
    throw std::invalid_argument("mesh lattice spacing must be > 0");
  if (!(s.scale > 0) || !std::isfinite(s.scale)) throw std::invalid_argument("mesh scale must be > 0");
  if (s.mesh.vertices.empty()) throw std::invalid_argument("the mesh has no vertices");
  Vec3 lo = s.mesh.vertices[0], hi = lo;
  for (const Vec3& v : s.mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  lo *= s.scale;
  hi *= s.scale;
  MeshGrid g;
  for (int d = 0; d < 3; ++d) {
    // The relative slack keeps an extent of n spacings at n cells despite rounding (STL stores
    // float32: 0.1 is 0.100000001).
    const double cells = std::max(1.0, std::ceil((hi[d] - lo[d]) / s.spacing * (1 - 1e-6)));
    g.cells[d] = cells < 9e15 ? static_cast<std::int64_t>(cells) : std::int64_t{9000000000000000};
    g.first[d] = 0.5 * (lo[d] + hi[d]) - 0.5 * (cells - 1) * s.spacing;
  }
  return g;
}

std::vector<std::uint8_t> inside_sites(const TriangleMesh& mesh, const MeshGrid& g, double a) {
  const std::int64_t nx = g.cells[0], ny = g.cells[1], nz = g.cells[2];
  // Crossings of each grid row (a line along x through (y_j, z_k)) with the surface.
  std::vector<std::vector<double>> rows(static_cast<std::size_t>(ny * nz));
  auto y_of = [&](std::int64_t j) { return g.first.y() + static_cast<double>(j) * a; };
  auto z_of = [&](std::int64_t k) { return g.first.z() + static_cast<double>(k) * a; };
  // Signed double area of (P, Q, p) in the (y, z) plane, always evaluated with the lower vertex
  // id first so that the two triangles sharing an edge get exactly opposite values. A zero (the
  // row passes through the edge's line) is broken by simulation of simplicity: p is moved by
  // (ε, ε²), so the sign is that of −Δz, or of Δy when Δz = 0. Returns 0 only for an edge
  // parallel to x (its triangles project to a segment and contain no perturbed point).
  auto side = [&](Index i, Index j, double py, double pz, double& value) -> int {
    const bool flip = i > j;
    const Vec3& P = mesh.vertices[flip ? j : i];
    const Vec3& Q = mesh.vertices[flip ? i : j];
    const double dy = Q.y() - P.y(), dz = Q.z() - P.z();
    double o = dy * (pz - P.z()) - dz * (py - P.y());
    int sign = o > 0 ? 1 : o < 0 ? -1 : (dz != 0 ? (dz < 0 ? 1 : -1) : (dy > 0 ? 1 : dy < 0 ? -1 : 0));
    if (flip) {
      o = -o;
      sign = -sign;
    }
    value = o;
    return sign;
  };
  for (const auto& tri : mesh.triangles) {
    const Vec3 &A = mesh.vertices[tri[0]], &B = mesh.vertices[tri[1]], &C = mesh.vertices[tri[2]];
    const double ylo = std::min({A.y(), B.y(), C.y()}), yhi = std::max({A.y(), B.y(), C.y()});
    const double zlo = std::min({A.z(), B.z(), C.z()}), zhi = std::max({A.z(), B.z(), C.z()});
    // Rows whose (y, z) may fall in the triangle's projection, one row of slack each way (the
    // exact test below decides).
    auto range = [&](double lo, double hi, double first, std::int64_t n) {
      const double a0 = std::floor((lo - first) / a) - 1, a1 = std::ceil((hi - first) / a) + 1;
      return std::pair<std::int64_t, std::int64_t>{
          static_cast<std::int64_t>(std::max(0.0, a0)),
          static_cast<std::int64_t>(std::min(static_cast<double>(n - 1), a1))};
    };
    const auto [j0, j1] = range(ylo, yhi, g.first.y(), ny);
    const auto [k0, k1] = range(zlo, zhi, g.first.z(), nz);
    for (std::int64_t k = k0; k <= k1; ++k)
      for (std::int64_t j = j0; j <= j1; ++j) {
        const double py = y_of(j), pz = z_of(k);
        double w0, w1, w2;  // barycentric weights (double areas opposite each corner)
        const int s0 = side(tri[1], tri[2], py, pz, w0);
        const int s1 = side(tri[2], tri[0], py, pz, w1);
        const int s2 = side(tri[0], tri[1], py, pz, w2);
        if (s0 == 0 || s0 != s1 || s1 != s2) continue;
        const double w = w0 + w1 + w2;
        if (w == 0 || !std::isfinite(w)) continue;
        const double x = (w0 * A.x() + w1 * B.x() + w2 * C.x()) / w;
        rows[static_cast<std::size_t>(k * ny + j)].push_back(
            std::clamp(x, std::min({A.x(), B.x(), C.x()}), std::max({A.x(), B.x(), C.x()})));
      }
  }
  // A site is inside when the ray from it along +x crosses the surface an odd number of times.
  std::vector<std::uint8_t> inside(static_cast<std::size_t>(nx * ny * nz), 0);
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j) {
      std::vector<double>& xs = rows[static_cast<std::size_t>(k * ny + j)];
      if (xs.empty()) continue;
      std::sort(xs.begin(), xs.end());
      std::size_t at_or_before = 0;  // crossings with x <= the site's
      for (std::int64_t i = 0; i < nx; ++i) {
        const double x = g.first.x() + static_cast<double>(i) * a;
        while (at_or_before < xs.size() && xs[at_or_before] <= x) ++at_or_before;
        inside[static_cast<std::size_t>((k * ny + j) * nx + i)] = (xs.size() - at_or_before) % 2;
      }
    }
  return inside;
}

std::vector<Index> add_mesh_lattice(World& world, const MeshLattice& s, Index body) {
  if (!(s.quanta_mass > 0)) throw std::invalid_argument("quanta_mass must be > 0");
  check_closed(s.mesh, "mesh");
  const MeshGrid g = mesh_grid(s);
  const auto [nx, ny, nz] = g.cells;
  if (static_cast<double>(nx) * static_cast<double>(ny) * static_cast<double>(nz) > 4e9)
    throw std::invalid_argument("the mesh lattice grid would have more than 4e9 sites");
  TriangleMesh scaled = s.mesh;
  for (Vec3& v : scaled.vertices) v *= s.scale;
  const std::vector<std::uint8_t> inside = inside_sites(scaled, g, s.spacing);

  // Sites inside, x fastest; then bonds to the neighbour shells as add_cubic_lattice makes them.
  constexpr Index kOutside = ~Index{0};
  std::vector<Index> site(inside.size(), kOutside);  // quanta of each grid site
  std::vector<Vec3> x;
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        const auto c = static_cast<std::size_t>((k * ny + j) * nx + i);
        if (!inside[c]) continue;
        site[c] = static_cast<Index>(x.size());
        x.push_back(g.first +
                    s.spacing * Vec3(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k)));
      }
  const std::vector<std::array<int, 3>> offsets = cubic_cell(s.shells).offsets;
  std::vector<std::pair<Index, Index>> pairs;
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        const Index a = site[static_cast<std::size_t>((k * ny + j) * nx + i)];
        if (a == kOutside) continue;
        for (const auto& o : offsets) {
          const std::int64_t I = i + o[0], J = j + o[1], K = k + o[2];
          if (I < 0 || J < 0 || K < 0 || I >= nx || J >= ny || K >= nz) continue;
          const Index b = site[static_cast<std::size_t>((K * ny + J) * nx + I)];
          if (b != kOutside) pairs.emplace_back(a, b);
        }
      }
  if (x.empty())
    throw std::invalid_argument("no lattice site falls inside the mesh (spacing " + num(s.spacing) +
                                " m is too coarse for it)");
  return add_bonded_points(world, std::move(x), std::move(pairs), s.quanta_mass, s.bond, s.isolated, body,
                           "mesh lattice");
}

}  // namespace qbond
