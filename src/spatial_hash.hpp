#pragma once
// A uniform grid hashed into a table of about 2n buckets, filled by counting sort: finding the
// pairs of points closer than the cell size costs time linear in the points (bounded density),
// with no allocation once the buffers have grown. Used by contacts and bond formation. Below it,
// pairs_within: the one-shot search between two subsets, inclusive of the radius (scene
// building, packings).
#include <array>
#include <cmath>
#include <cstdint>
#include <algorithm>
#include <unordered_map>
#include <vector>

#include "qbond/math.hpp"

namespace qbond {

class SpatialHash {
 public:
  // Bins `pos` into cells of side `cell` (> 0).
  void build(const std::vector<Vec3>& pos, double cell) {
    const std::size_t n = pos.size();
    cell_ = cell;
    table_ = 1;
    while (table_ < 2 * n) table_ <<= 1;
    cells_.resize(n);
    start_.assign(table_ + 1, 0);
    for (std::size_t i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) cells_[i][k] = static_cast<std::int64_t>(std::floor(pos[i][k] / cell));
      ++start_[hash(cells_[i]) + 1];
    }
    for (std::size_t b = 0; b < table_; ++b) start_[b + 1] += start_[b];
    bucket_.resize(n);
    fill_.assign(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < n; ++i) bucket_[fill_[hash(cells_[i])]++] = static_cast<Index>(i);
  }

  // Calls visit(i, j) for every pair i < j closer than the cell size, in increasing i, then in
  // the grid's scan order (deterministic for given points).
  template <class F>
  void pairs(const std::vector<Vec3>& pos, F&& visit) const {
    for (std::size_t q = 0; q < cells_.size(); ++q) {
      const auto i = static_cast<Index>(q);
      // hash() of the 27 cells around i's from each axis's three terms: 9 multiplications, not 81.
      std::uint64_t term[3][3];
      for (int a = 0; a < 3; ++a)
        for (int d = 0; d < 3; ++d) term[a][d] = axis_term(a, cells_[i][a] + d - 1);
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const std::array<std::int64_t, 3> c{cells_[i][0] + dx, cells_[i][1] + dy, cells_[i][2] + dz};
            const std::size_t h = (term[0][dx + 1] ^ term[1][dy + 1] ^ term[2][dz + 1]) & (table_ - 1);
            for (Index k = start_[h]; k < start_[h + 1]; ++k) {
              const Index j = bucket_[k];
              // Other cells sharing the bucket; compared by element (the array's != is a
              // memcmp call, a tenth of a contact step).
              const auto& cj = cells_[j];
              if (j <= i || cj[0] != c[0] || cj[1] != c[1] || cj[2] != c[2]) continue;
              if ((pos[j] - pos[i]).squaredNorm() >= cell_ * cell_) continue;
              visit(i, j);
            }
          }
    }
  }

 private:
  static std::uint64_t axis_term(int axis, std::int64_t c) {
    constexpr std::uint64_t kPrime[3] = {73856093u, 19349663u, 83492791u};
    return static_cast<std::uint64_t>(c) * kPrime[axis];
  }
  std::size_t hash(const std::array<std::int64_t, 3>& c) const {
    return static_cast<std::size_t>(axis_term(0, c[0]) ^ axis_term(1, c[1]) ^ axis_term(2, c[2])) &
           (table_ - 1);
  }

  double cell_ = 1;
  std::size_t table_ = 1;
  std::vector<std::array<std::int64_t, 3>> cells_;
  std::vector<Index> start_, fill_, bucket_;
};

/// Visits every pair (a, b) with a from `from`, b from `to`, a != b and |x_a − x_b| <= radius,
/// using a uniform grid of cell `radius` (cost linear in the quanta for bounded density). Pairs
/// come in increasing a, then increasing b.
template <class F>
void pairs_within(const std::vector<Vec3>& x, const std::vector<Index>& from, const std::vector<Index>& to,
                  double radius, F&& visit) {
  auto cell = [&](const Vec3& p) {
    return std::array<std::int64_t, 3>{static_cast<std::int64_t>(std::floor(p.x() / radius)),
                                       static_cast<std::int64_t>(std::floor(p.y() / radius)),
                                       static_cast<std::int64_t>(std::floor(p.z() / radius))};
  };
  auto key = [](std::int64_t a, std::int64_t b, std::int64_t c) {
    return static_cast<std::uint64_t>(a) * 73856093u ^ static_cast<std::uint64_t>(b) * 19349663u ^
           static_cast<std::uint64_t>(c) * 83492791u;
  };
  std::unordered_map<std::uint64_t, std::vector<Index>> grid;
  for (Index b : to) {
    const auto c = cell(x[b]);
    grid[key(c[0], c[1], c[2])].push_back(b);
  }
  std::vector<Index> near;
  for (Index a : from) {
    const auto c = cell(x[a]);
    near.clear();
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (auto it = grid.find(key(c[0] + dx, c[1] + dy, c[2] + dz)); it != grid.end())
            near.insert(near.end(), it->second.begin(), it->second.end());
    std::sort(near.begin(), near.end());
    near.erase(std::unique(near.begin(), near.end()), near.end());  // hash collisions repeat cells
    for (Index b : near)
      if (b != a && (x[a] - x[b]).norm() <= radius) visit(a, b);
  }
}

}  // namespace qbond
