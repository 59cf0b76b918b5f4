#pragma once
// A uniform grid whose rows are hashed into a table of about 2n buckets, filled by counting sort:
// finding the pairs of points closer than the cell size costs time linear in the points (bounded
// density; a binary search in a row's points), with no allocation once the buffers have grown.
// Used by contacts and bond formation. Below it, pairs_within: the one-shot search between two
// subsets, inclusive of the radius (scene building, packings).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "qbond/core/math.hpp"

namespace qbond {

class SpatialHash {
 public:
  // Bins `pos` into cells of side `cell` (> 0): the grid's rows along x (cells of one y and z)
  // hashed into the table, each bucket's points sorted by cell (y, z, then x), in increasing index
  // within a cell, so that a row's three cells around a point are one contiguous range.
  void build(const std::vector<Vec3>& pos, double cell) {
    const std::size_t n = pos.size();
    cell_ = cell;
    table_ = 1;
    while (table_ < 2 * n) table_ <<= 1;
    cells_.resize(n);
    start_.assign(table_ + 1, 0);
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3& p = pos[i];
      cells_[i] =
          coordinate(p.y(), cell) << 2 * kBits | coordinate(p.z(), cell) << kBits | coordinate(p.x(), cell);
      ++start_[row_hash(cells_[i]) + 1];
    }
    for (std::size_t b = 0; b < table_; ++b) start_[b + 1] += start_[b];
    bucket_.resize(n);
    keys_.resize(n);
    fill_.assign(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t k = fill_[row_hash(cells_[i])]++;
      bucket_[k] = static_cast<Index>(i);
      keys_[k] = cells_[i];
    }
    // Filled in increasing index; an insertion sort (stable) by cell on each bucket's few points.
    for (std::size_t b = 0; b < table_; ++b)
      for (std::size_t k = start_[b] + 1; k < start_[b + 1]; ++k)
        for (std::size_t m = k; m > start_[b] && keys_[m] < keys_[m - 1]; --m) {
          std::swap(keys_[m], keys_[m - 1]);
          std::swap(bucket_[m], bucket_[m - 1]);
        }
  }

  // Calls visit(i, j) for every pair i < j closer than the cell size, in increasing i, then in
  // the grid's scan order: the 27 cells around i's by z, y, x, each cell's points in increasing
  // index (deterministic for given points).
  template <class F>
  void pairs(const std::vector<Vec3>& pos, F&& visit) const {
    for (std::size_t q = 0; q < cells_.size(); ++q) {
      const auto i = static_cast<Index>(q);
      const std::uint64_t c = cells_[i], x = c & kMask;
      for (std::uint64_t z = (c >> kBits & kMask) - 1, z1 = z + 2; z <= z1; ++z)
        for (std::uint64_t y = (c >> 2 * kBits) - 1, y1 = y + 2; y <= y1; ++y) {
          // Row (y, z)'s points with x from x − 1 to x + 1, the three cells in scan order.
          const std::uint64_t row = y << 2 * kBits | z << kBits, lo = row | (x - 1), hi = row | (x + 1);
          const std::size_t h = row_hash(row);
          const std::size_t last = start_[h + 1];
          for (std::size_t k = first_not_below(start_[h], last, lo); k != last && keys_[k] <= hi; ++k) {
            const Index j = bucket_[k];
            if (j <= i) continue;
            if ((pos[j] - pos[i]).squaredNorm() >= cell_ * cell_) continue;
            visit(i, j);
          }
        }
    }
  }

 private:
  // A cell is three coordinates of kBits bits packed as y, z, x (y highest): keys in increasing
  // order are cells by y, then z, then x. Each is floor(p / cell) clamped to ±(2^20 − 2) (cells
  // a point apart stay neighbours; NaN goes to the low end, and no cast overflows) plus 2^20, so
  // that it and its neighbours ±1 are in [0, 2^21).
  static constexpr int kBits = 21;
  static constexpr std::uint64_t kMask = (std::uint64_t{1} << kBits) - 1;
  static std::uint64_t coordinate(double p, double cell) {
    constexpr double kBias = double(std::uint64_t{1} << (kBits - 1)), kMax = kBias - 2;
    const double c = std::floor(p / cell);
    return static_cast<std::uint64_t>((c >= -kMax ? (c <= kMax ? c : kMax) : -kMax) + kBias);
  }
  // The first k in [first, last) with keys_[k] >= key (last if none): a binary search whose
  // halving is a conditional move, not a branch (std::lower_bound's mispredict on a liquid's
  // rows, which bond formation searches every step).
  std::size_t first_not_below(std::size_t first, std::size_t last, std::uint64_t key) const {
    std::size_t len = last - first;
    while (len > 0) {
      const std::size_t half = len / 2;
      const bool below = keys_[first + half] < key;
      first = below ? first + half + 1 : first;
      len = below ? len - half - 1 : half;
    }
    return first;
  }
  // The bucket of a cell's row (its y and z).
  std::size_t row_hash(std::uint64_t cell) const {
    return static_cast<std::size_t>(((cell >> 2 * kBits) * 19349663u) ^
                                    ((cell >> kBits & kMask) * 83492791u)) &
           (table_ - 1);
  }

  double cell_ = 1;
  std::size_t table_ = 1;
  std::vector<std::uint64_t> cells_;  // by point
  std::vector<std::uint64_t> keys_;   // cells_[bucket_[k]]
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
