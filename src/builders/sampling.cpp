#include "qbond/builders/sampling.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

#include "builders/bonded_points.hpp"
#include "heuristics/spatial_hash.hpp"
#include "qbond/core/rng.hpp"

namespace qbond {
namespace {

// A packing's own random stream, derived from its seed so that it does not repeat the run's
// stream (which the scene seeds with the same number).
Rng packing_rng(std::uint64_t seed) {
  Rng mix{seed ^ 0x7061636b696e6721ull};  // "packing!"
  return Rng{mix.next()};
}

// Uniform integer in [0, n) (n > 0); the bias of the multiply is below 2^-53 n.
std::size_t pick(Rng& rng, std::size_t n) {
  return std::min(n - 1, static_cast<std::size_t>(rng.uniform() * static_cast<double>(n)));
}

/// A dense background grid over the box for "is an accepted point closer than r to p?": with
/// cells of at least r such a point lies in the 27 cells around p's. Each cell heads a list of
/// its points (4 bytes a cell and a point). The cell size changes the speed, never the answer.
class DiskGrid {
 public:
  /// Cells of side max(r, the side that gives about one cell per expected point).
  DiskGrid(const Vec3& size, double r, double expected_points, bool flat) {
    const double volume = flat ? size.x() * size.y() : size.prod();
    const double per_point = volume / std::max(1.0, expected_points);
    cell_ = std::max(r, flat ? std::sqrt(per_point) : std::cbrt(per_point));
    for (int d = 0; d < 3; ++d)
      n_[d] = (flat && d == 2)
                  ? 1
                  : std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil(size[d] / cell_)));
    head_.assign(static_cast<std::size_t>(n_[0] * n_[1] * n_[2]), -1);
  }
  bool occupied(const std::vector<Vec3>& x, const Vec3& p, double r) const {
    const auto c = cell_of(p);
    const double r2 = r * r;
    for (std::int64_t k = std::max<std::int64_t>(0, c[2] - 1); k <= std::min(n_[2] - 1, c[2] + 1); ++k)
      for (std::int64_t j = std::max<std::int64_t>(0, c[1] - 1); j <= std::min(n_[1] - 1, c[1] + 1); ++j)
        for (std::int64_t i = std::max<std::int64_t>(0, c[0] - 1); i <= std::min(n_[0] - 1, c[0] + 1); ++i)
          for (std::int32_t q = head_[slot(i, j, k)]; q >= 0; q = next_[static_cast<std::size_t>(q)])
            if ((x[static_cast<std::size_t>(q)] - p).squaredNorm() < r2) return true;
    return false;
  }
  /// Adds point `id` (ids must come 0, 1, 2, ...).
  void insert(const Vec3& p) {
    const auto c = cell_of(p);
    std::int32_t& h = head_[slot(c[0], c[1], c[2])];
    next_.push_back(h);
    h = static_cast<std::int32_t>(next_.size() - 1);
  }

 private:
  std::array<std::int64_t, 3> cell_of(const Vec3& p) const {
    std::array<std::int64_t, 3> c{};
    for (int d = 0; d < 3; ++d)
      c[d] = std::clamp<std::int64_t>(clamped_floor(p[d] / cell_, static_cast<double>(n_[d])), 0, n_[d] - 1);
    return c;
  }
  std::size_t slot(std::int64_t i, std::int64_t j, std::int64_t k) const {
    return static_cast<std::size_t>((k * n_[1] + j) * n_[0] + i);
  }
  double cell_ = 0;
  std::array<std::int64_t, 3> n_{};
  std::vector<std::int32_t> head_;  // first point of each cell, -1: none
  std::vector<std::int32_t> next_;  // next point in the same cell, -1: none
};

void check_packing(const PointPacking& s) {
  if (!(s.size.x() > 0 && s.size.y() > 0 && s.size.z() >= 0) || !s.size.allFinite())
    throw std::invalid_argument("packing size must be > 0 in x and y and >= 0 in z");
  if (!std::isfinite(s.min_distance) || s.min_distance < 0)
    throw std::invalid_argument("min_distance must be >= 0");
  if (s.kind == PointPacking::poisson && !(s.min_distance > 0))
    throw std::invalid_argument("a Poisson-disk packing needs min_distance > 0");
  if (s.kind == PointPacking::random && s.count == 0)
    throw std::invalid_argument("a random packing needs count > 0");
  if (!(s.bond_radius > 0) || !std::isfinite(s.bond_radius))
    throw std::invalid_argument("bond_radius must be > 0");
  if (!(s.quanta_mass > 0)) throw std::invalid_argument("quanta_mass must be > 0");
  if (max_points(s) > 2e9) throw std::invalid_argument("the packing would hold more than 2e9 points");
}

}  // namespace

double max_points(const PointPacking& s) {
  const bool flat = s.size.z() == 0;
  const double r = s.min_distance;
  if (!(r > 0)) return static_cast<double>(s.count);
  // Disjoint balls of radius r/2 in the box grown by r/2: Kepler's π/√18 in 3D, π/√12 in 2D.
  const double bound =
      flat ? (s.size.x() + r) * (s.size.y() + r) / (r * r) * (1 / std::sqrt(3.0)) * 2
           : (s.size.x() + r) * (s.size.y() + r) * (s.size.z() + r) / (r * r * r) * std::sqrt(2.0);
  return s.count > 0 ? std::min(bound, static_cast<double>(s.count)) : bound;
}

std::vector<Vec3> sample_points(const PointPacking& s) {
  check_packing(s);
  const bool flat = s.size.z() == 0;
  const double r = s.min_distance;
  Rng rng = packing_rng(s.seed);
  auto uniform_in_box = [&] {
    const double x = rng.uniform() * s.size.x(), y = rng.uniform() * s.size.y();
    return Vec3(x, y, flat ? 0.0 : rng.uniform() * s.size.z());
  };
  auto in_box = [&](const Vec3& p) { return (p.array() >= 0).all() && (p.array() <= s.size.array()).all(); };
  std::vector<Vec3> x;

  if (s.kind == PointPacking::random) {
    x.reserve(s.count);
    if (!(r > 0)) {
      while (x.size() < s.count) x.push_back(uniform_in_box());
      return x;
    }
    // Dart throwing: a grid of cell r holds every point within r of a dart in the 27 cells around.
    DiskGrid grid(s.size, r, static_cast<double>(s.count), flat);
    const std::size_t attempts = 100 * s.count + 1000;
    for (std::size_t a = 0; a < attempts && x.size() < s.count; ++a) {
      const Vec3 p = uniform_in_box();
      if (grid.occupied(x, p, r)) continue;
      grid.insert(p);
      x.push_back(p);
    }
    if (x.size() < s.count)
      throw std::invalid_argument("a random packing could place only " + std::to_string(x.size()) + " of " +
                                  std::to_string(s.count) + " points " + num(r) + " m apart in " +
                                  std::to_string(attempts) + " darts (lower count or min_distance)");
    return x;
  }

  // Bridson (2007), "Fast Poisson disk sampling in arbitrary dimensions": from a random active
  // point try k candidates in the shell [r, 2r] around it, keep the first no point is closer than
  // r to; a point whose k candidates all fail retires. (Bridson's grid has cells of r/√d holding
  // one point each; cells of r and lists visit 27 cells instead of 125.)
  constexpr int kCandidates = 30;
  DiskGrid grid(s.size, r, max_points(s), flat);
  std::vector<Index> active;
  auto accept = [&](const Vec3& p) {
    grid.insert(p);
    active.push_back(static_cast<Index>(x.size()));
    x.push_back(p);
  };
  accept(uniform_in_box());
  // A candidate uniform in the shell: rejection from the cube [-2r, 2r]^d (about half of the
  // draws land in the shell), so only +, × and comparisons are needed.
  auto shell_offset = [&] {
    for (;;) {
      const Vec3 o((4 * rng.uniform() - 2) * r, (4 * rng.uniform() - 2) * r,
                   flat ? 0.0 : (4 * rng.uniform() - 2) * r);
      const double d2 = o.squaredNorm();
      if (d2 >= r * r && d2 <= 4 * r * r) return o;
    }
  };
  while (!active.empty() && (s.count == 0 || x.size() < s.count)) {
    const std::size_t k = pick(rng, active.size());
    const Vec3 centre = x[active[k]];
    bool placed = false;
    for (int t = 0; t < kCandidates && !placed; ++t) {
      const Vec3 p = centre + shell_offset();
      if (!in_box(p) || grid.occupied(x, p, r)) continue;
      accept(p);
      placed = true;
    }
    if (!placed) {
      active[k] = active.back();
      active.pop_back();
    }
  }
  return x;
}

std::vector<std::pair<Index, Index>> pairs_within_radius(const std::vector<Vec3>& x, double radius,
                                                         std::size_t max_pairs) {
  if (!(radius > 0)) throw std::invalid_argument("pair radius must be > 0");
  std::vector<Index> all(x.size());
  std::iota(all.begin(), all.end(), Index{0});
  std::vector<std::pair<Index, Index>> pairs;
  // Visited in increasing a, then b: the pairs come out sorted.
  pairs_within(x, all, all, radius, [&](Index a, Index b) {
    if (a >= b) return;
    if (pairs.size() == max_pairs)
      throw std::length_error("more than " + std::to_string(max_pairs) + " pairs lie within " + num(radius) + " m");
    pairs.emplace_back(a, b);
  });
  return pairs;
}

std::vector<Index> add_bonded_points(World& world, std::vector<Vec3> x,
                                     std::vector<std::pair<Index, Index>> pairs, double mass,
                                     const BondSpec& bond, Isolated isolated, Index body, const char* what) {
  std::vector<std::uint8_t> bonded(x.size(), 0);
  for (const auto& [a, b] : pairs) bonded[a] = bonded[b] = 1;
  const auto lonely = static_cast<std::size_t>(std::count(bonded.begin(), bonded.end(), 0));
  if (lonely > 0 && isolated == Isolated::error) {
    const auto first = static_cast<std::size_t>(std::find(bonded.begin(), bonded.end(), 0) - bonded.begin());
    throw std::invalid_argument(std::string(what) + ": " + std::to_string(lonely) + " of " +
                                std::to_string(x.size()) + " points have no bond (the first at [" +
                                num(x[first].x()) + ", " + num(x[first].y()) + ", " + num(x[first].z()) +
                                "]); widen the bond radius or drop them");
  }
  if (lonely > 0 && isolated == Isolated::drop) {
    std::vector<Index> renumber(x.size());
    std::size_t kept = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      renumber[i] = static_cast<Index>(kept);
      if (bonded[i]) x[kept++] = x[i];
    }
    x.resize(kept);
    for (auto& [a, b] : pairs) {
      a = renumber[a];
      b = renumber[b];
    }
  }
  std::vector<Index> ids;
  ids.reserve(x.size());
  for (const Vec3& p : x) ids.push_back(world.add_quanta(p, Vec3::Zero(), mass, body));
  BondSpec spec = bond;
  spec.rest_length = -1;
  for (const auto& [a, b] : pairs) world.add_bond(ids[a], ids[b], spec);
  return ids;
}

std::vector<Index> add_point_packing(World& world, const PointPacking& s, Index body) {
  std::vector<Vec3> x = sample_points(s);
  auto pairs = pairs_within_radius(x, s.bond_radius, s.max_bonds);
  return add_bonded_points(world, std::move(x), std::move(pairs), s.quanta_mass, s.bond, s.isolated, body,
                           "point packing");
}

}  // namespace qbond
