#pragma once
// A uniform grid whose points are binned by counting sort: finding the pairs of points closer
// than the cell size costs time linear in the points (bounded density), with no allocation once
// the buffers have grown. The buckets, by what the points span (with empty cells around them):
// - cells: one bucket a cell, when the box of cells has at most kDenseCells a point (a liquid's
//   body): the three cells of a row around a point are one range found by arithmetic;
// - rows: one bucket a row (cells of one y and z, along x) when the rows' table is small (a gas
//   in its box): the nine rows around a point found by arithmetic, a binary search in each;
// - hashed rows: points scattered far apart, rows hashed into a table of about 2n buckets.
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
  // Bins `pos` into cells of side `cell` (> 0): each bucket's points sorted by cell (y, z, then
  // x), in increasing index within a cell, so that a row's three cells around a point are one
  // contiguous range.
  void build(const std::vector<Vec3>& pos, double cell) {
    const std::size_t n = pos.size();
    cell_ = cell;
    cells_.resize(n);
    std::uint64_t lo[3] = {kMask, kMask, kMask}, hi[3] = {0, 0, 0};  // x, y, z
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3& p = pos[i];
      const std::uint64_t x = coordinate(p.x(), cell), y = coordinate(p.y(), cell), z = coordinate(p.z(), cell);
      cells_[i] = y << 2 * kBits | z << kBits | x;
      lo[0] = std::min(lo[0], x);
      hi[0] = std::max(hi[0], x);
      lo[1] = std::min(lo[1], y);
      hi[1] = std::max(hi[1], y);
      lo[2] = std::min(lo[2], z);
      hi[2] = std::max(hi[2], z);
    }
    // The box of cells from lo − 1 to hi + 1 (at most 2^21 a side: no product overflows).
    const std::uint64_t nx = hi[0] - lo[0] + 3, ny = hi[1] - lo[1] + 3, nz = hi[2] - lo[2] + 3;
    if (n > 0 && nx * ny * nz <= kDenseCells * n + 64) {
      layout_ = Layout::cells;
      width_ = nx;
      plane_ = nx * ny;
      origin_ = (lo[2] - 1) * plane_ + (lo[1] - 1) * width_ + (lo[0] - 1);
      table_ = plane_ * nz;
    } else if (n > 0 && ny * nz <= kDenseRows * n + 64) {
      layout_ = Layout::rows;
      plane_ = ny;
      origin_ = (lo[2] - 1) * plane_ + (lo[1] - 1);
      table_ = plane_ * nz;
    } else {
      layout_ = Layout::hashed;
      table_ = 1;
      while (table_ < 2 * n) table_ <<= 1;
    }
    switch (layout_) {
      case Layout::cells: return fill<Layout::cells>();
      case Layout::rows: return fill<Layout::rows>();
      case Layout::hashed: return fill<Layout::hashed>();
    }
  }

  // Calls visit(i, j) for every pair i < j closer than the cell size, in increasing i, then in
  // the grid's scan order: the 27 cells around i's by z, y, x, each cell's points in increasing
  // index (deterministic for given points).
  template <class F>
  void pairs(const std::vector<Vec3>& pos, F&& visit) const {
    switch (layout_) {
      case Layout::cells: return scan<Layout::cells>(pos, visit);
      case Layout::rows: return scan<Layout::rows>(pos, visit);
      case Layout::hashed: return scan<Layout::hashed>(pos, visit);
    }
  }

 private:
  enum class Layout : std::uint8_t { cells, rows, hashed };

  // build's counting sort of the points into the buckets, for one layout.
  template <Layout kLayout>
  void fill() {
    const std::size_t n = cells_.size();
    start_.assign(table_ + 1, 0);
    for (std::size_t i = 0; i < n; ++i) ++start_[bucket<kLayout>(cells_[i]) + 1];
    for (std::size_t b = 0; b < table_; ++b) start_[b + 1] += start_[b];
    bucket_.resize(n);
    keys_.resize(n);
    fill_.assign(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t k = fill_[bucket<kLayout>(cells_[i])]++;
      bucket_[k] = static_cast<Index>(i);
      keys_[k] = cells_[i];
    }
    if (kLayout == Layout::cells) return;  // a bucket a cell, filled in increasing index
    // An insertion sort (stable) by cell on each bucket's few points.
    for (std::size_t b = 0; b < table_; ++b)
      for (std::size_t k = start_[b] + 1; k < start_[b + 1]; ++k)
        for (std::size_t m = k; m > start_[b] && keys_[m] < keys_[m - 1]; --m) {
          std::swap(keys_[m], keys_[m - 1]);
          std::swap(bucket_[m], bucket_[m - 1]);
        }
  }

  // pairs, for one layout.
  template <Layout kLayout, class F>
  void scan(const std::vector<Vec3>& pos, F& visit) const {
    constexpr std::uint64_t kY = std::uint64_t{1} << 2 * kBits, kZ = std::uint64_t{1} << kBits;
    constexpr std::size_t kAcross = kLayout == Layout::cells ? 1 : 0;  // x's neighbours a bucket apart
    const std::size_t step = kLayout == Layout::cells ? width_ : 1;       // y's
    for (std::size_t q = 0; q < cells_.size(); ++q) {
      const auto i = static_cast<Index>(q);
      const std::uint64_t c = cells_[i];
      // Cells, rows: the bucket of (x − 1, y − 1, z − 1)'s cell or row; y's step is width_, z's plane_.
      const std::size_t corner = kLayout != Layout::hashed ? bucket<kLayout>(c) - plane_ - step - kAcross : 0;
      for (std::uint64_t dz = 0; dz < 3; ++dz)
        for (std::uint64_t dy = 0; dy < 3; ++dy) {
          // Row (y − 1 + dy, z − 1 + dz)'s points with x from x − 1 to x + 1, the three cells in
          // scan order (coordinates are at least 2: no borrow). Cells: their three buckets.
          const std::uint64_t at = c + dy * kY + dz * kZ - kY - kZ;
          const std::size_t h = kLayout != Layout::hashed ? corner + dz * plane_ + dy * step : bucket<kLayout>(at);
          std::size_t k = start_[h];
          const std::size_t last = start_[h + 1 + 2 * kAcross];
          if (k == last) continue;
          if constexpr (kLayout != Layout::cells) k = first_not_below(k, last, at - 1);
          for (; k != last && (kLayout == Layout::cells || keys_[k] <= at + 1); ++k) {
            const Index j = bucket_[k];
            if (j <= i) continue;
            if ((pos[j] - pos[i]).squaredNorm() >= cell_ * cell_) continue;
            visit(i, j);
          }
        }
    }
  }

  // A cell is three coordinates of kBits bits packed as y, z, x (y highest): keys in increasing
  // order are cells by y, then z, then x. Each is floor(p / cell) clamped to ±(2^20 − 2) (cells
  // a point apart stay neighbours; NaN goes to the low end, and no cast overflows) plus 2^20, so
  // that it and its neighbours ±1 are in [0, 2^21).
  static constexpr int kBits = 21;
  static constexpr std::uint64_t kMask = (std::uint64_t{1} << kBits) - 1;
  // The tables of cells and of rows are used up to this many buckets a point (besides a few).
  static constexpr std::uint64_t kDenseCells = 8, kDenseRows = 4;
  static std::uint64_t coordinate(double p, double cell) {
    constexpr double kBias = double(std::uint64_t{1} << (kBits - 1)), kMax = kBias - 2;
    // The quotient clamped first (NaN to the low end), then floored by truncation: within the
    // clamp, an integer's floor is the truncation less one where that lies above the quotient.
    const double v = p / cell;
    if (!(v >= -kMax)) return static_cast<std::uint64_t>(kBias - kMax);
    if (v >= kMax) return static_cast<std::uint64_t>(kBias + kMax);
    const auto t = static_cast<std::int64_t>(v);
    return static_cast<std::uint64_t>(t - (static_cast<double>(t) > v) + static_cast<std::int64_t>(kBias));
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
  // A cell's bucket: its place in the table of cells, its row's in the table of rows, or its row's hash.
  template <Layout kLayout>
  std::size_t bucket(std::uint64_t cell) const {
    const std::uint64_t y = cell >> 2 * kBits, z = cell >> kBits & kMask;
    if (kLayout == Layout::cells) return static_cast<std::size_t>(z * plane_ + y * width_ + (cell & kMask) - origin_);
    if (kLayout == Layout::rows) return static_cast<std::size_t>(z * plane_ + y - origin_);
    return static_cast<std::size_t>((y * 19349663u) ^ (z * 83492791u)) & (table_ - 1);
  }

  double cell_ = 1;
  Layout layout_ = Layout::hashed;
  // Cells: a bucket's place is z · plane_ + y · width_ + x − origin_; rows: z · plane_ + y − origin_.
  std::uint64_t width_ = 0, plane_ = 0, origin_ = 0;
  std::size_t table_ = 1;
  std::vector<std::uint64_t> cells_;  // by point
  std::vector<std::uint64_t> keys_;   // cells_[bucket_[k]]
  std::vector<Index> start_, fill_, bucket_;
};

/// floor(v) as a cell's index, v first clamped to [−most, most] (NaN to −most), so that no cast
/// overflows whatever the coordinate and the cell (a point far out, a cell of 1e-44 m).
inline std::int64_t clamped_floor(double v, double most) {
  if (!(v >= -most)) return static_cast<std::int64_t>(-most);
  if (v >= most) return static_cast<std::int64_t>(most);
  return static_cast<std::int64_t>(std::floor(v));
}

/// Visits every pair (a, b) with a from `from`, b from `to`, a != b and |x_a − x_b| <= radius,
/// using a uniform grid of cell `radius` (cost linear in the quanta for bounded density). Pairs
/// come in increasing a, then increasing b.
template <class F>
void pairs_within(const std::vector<Vec3>& x, const std::vector<Index>& from, const std::vector<Index>& to,
                  double radius, F&& visit) {
  // Far cells clamped together stay correct (each pair is tested by its distance), only slower.
  constexpr double kMost = double(std::int64_t{1} << 62);
  auto cell = [&](const Vec3& p) {
    return std::array<std::int64_t, 3>{clamped_floor(p.x() / radius, kMost), clamped_floor(p.y() / radius, kMost),
                                       clamped_floor(p.z() / radius, kMost)};
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
