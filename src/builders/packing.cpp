#include "qbond/builders/packing.hpp"

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <map>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

#include "qbond/io/files.hpp"
#include "qbond/core/rng.hpp"
#include "heuristics/spatial_hash.hpp"

namespace qbond {
namespace {

std::string num(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// ---------------------------------------------------------------------------------------------
// Point packings

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
      c[d] = std::clamp<std::int64_t>(static_cast<std::int64_t>(std::floor(p[d] / cell_)), 0, n_[d] - 1);
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

std::vector<std::pair<Index, Index>> pairs_within_radius(const std::vector<Vec3>& x, double radius) {
  if (!(radius > 0)) throw std::invalid_argument("pair radius must be > 0");
  std::vector<Index> all(x.size());
  std::iota(all.begin(), all.end(), Index{0});
  std::vector<std::pair<Index, Index>> pairs;
  // Visited in increasing a, then b: the pairs come out sorted.
  pairs_within(x, all, all, radius, [&](Index a, Index b) {
    if (a < b) pairs.emplace_back(a, b);
  });
  return pairs;
}

namespace {

/// Adds points and bonds to the world, first handling the points no pair touches.
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

}  // namespace

std::vector<Index> add_point_packing(World& world, const PointPacking& s, Index body) {
  std::vector<Vec3> x = sample_points(s);
  auto pairs = pairs_within_radius(x, s.bond_radius);
  return add_bonded_points(world, std::move(x), std::move(pairs), s.quanta_mass, s.bond, s.isolated, body,
                           "point packing");
}

// ---------------------------------------------------------------------------------------------
// Mesh files

namespace {

[[noreturn]] void malformed(const std::string& name, std::size_t line, const std::string& rule) {
  throw std::runtime_error(name + (line ? ":" + std::to_string(line) : "") + ": " + rule);
}

/// Whitespace-separated tokens of one line.
std::vector<std::string_view> tokens(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() &&
           (line[i] == ' ' || line[i] == '\t' || line[i] == '\r' || line[i] == '\f' || line[i] == '\v'))
      ++i;
    const std::size_t start = i;
    while (i < line.size() &&
           !(line[i] == ' ' || line[i] == '\t' || line[i] == '\r' || line[i] == '\f' || line[i] == '\v'))
      ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

bool parse_double(std::string_view t, double& v) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return r.ec == std::errc() && r.ptr == t.data() + t.size() && std::isfinite(v);
}

bool parse_long(std::string_view t, long long& v) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

std::string quoted(std::string_view t) {
  std::string q = "'";  // appended piecewise: GCC 12 warns (-Wrestrict) falsely on "'" + string + ...
  q.append(t.substr(0, 40));
  q.append(t.size() > 40 ? "...'" : "'");
  return q;
}

/// Merges vertices with identical coordinates (STL stores every triangle's corners separately).
class Welder {
 public:
  explicit Welder(TriangleMesh& mesh) : mesh_(mesh) {}
  Index add(const Vec3& p) {
    // + 0.0 turns −0 into +0, so the two zeros weld.
    const std::array<std::uint64_t, 3> key{std::bit_cast<std::uint64_t>(p.x() + 0.0),
                                           std::bit_cast<std::uint64_t>(p.y() + 0.0),
                                           std::bit_cast<std::uint64_t>(p.z() + 0.0)};
    const auto [it, fresh] = ids_.emplace(key, static_cast<Index>(mesh_.vertices.size()));
    if (fresh) mesh_.vertices.push_back(p);
    return it->second;
  }

 private:
  TriangleMesh& mesh_;
  std::map<std::array<std::uint64_t, 3>, Index> ids_;
};

bool degenerate(const std::array<Index, 3>& t) { return t[0] == t[1] || t[1] == t[2] || t[0] == t[2]; }

std::string lower_extension(const std::string& name) {
  std::string ext = std::filesystem::path(name).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace

TriangleMesh parse_obj(std::string_view text, const std::string& name) {
  TriangleMesh mesh;
  std::size_t line_no = 0;
  std::vector<Index> face;
  while (!text.empty()) {
    const std::size_t end = std::min(text.find('\n'), text.size());
    std::string_view line = text.substr(0, end);
    text.remove_prefix(std::min(end + 1, text.size()));
    ++line_no;
    if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    const auto t = tokens(line);
    if (t.empty()) continue;
    if (t[0] == "v") {
      if (t.size() < 4) malformed(name, line_no, "a vertex needs 3 coordinates: v x y z");
      double c[3];
      for (int d = 0; d < 3; ++d)
        if (!parse_double(t[1 + d], c[d]))
          malformed(name, line_no, "vertex coordinate " + quoted(t[1 + d]) + " is not a finite number");
      for (std::size_t k = 4; k < t.size(); ++k) {
        double ignored;
        if (!parse_double(t[k], ignored))
          malformed(name, line_no, "vertex value " + quoted(t[k]) + " is not a finite number");
      }
      mesh.vertices.emplace_back(c[0], c[1], c[2]);
    } else if (t[0] == "f") {
      if (t.size() < 4) malformed(name, line_no, "a face needs at least 3 vertices");
      face.clear();
      for (std::size_t k = 1; k < t.size(); ++k) {
        const std::string_view ref = t[k].substr(0, t[k].find('/'));  // a, a/t, a//n, a/t/n
        long long v = 0;
        if (!parse_long(ref, v) || v == 0)
          malformed(
              name, line_no,
              "face vertex " + quoted(t[k]) + " is not a non-zero integer (1-based, or negative: relative)");
        const long long nv = static_cast<long long>(mesh.vertices.size());
        const long long id = v > 0 ? v - 1 : nv + v;
        if (id < 0 || id >= nv)
          malformed(name, line_no,
                    "face vertex " + std::to_string(v) + " does not exist (" + std::to_string(nv) +
                        " vertices defined so far)");
        face.push_back(static_cast<Index>(id));
      }
      for (std::size_t a = 0; a < face.size(); ++a)
        for (std::size_t b = a + 1; b < face.size(); ++b)
          if (face[a] == face[b])
            malformed(name, line_no,
                      "face uses vertex " + std::to_string(face[a] + 1) + " twice (degenerate)");
      for (std::size_t k = 1; k + 1 < face.size(); ++k)
        mesh.triangles.push_back({face[0], face[k], face[k + 1]});
    }
    // Everything else (vt, vn, o, g, s, usemtl, mtllib, l, ...) does not change the shape.
  }
  if (mesh.triangles.empty()) malformed(name, 0, "no faces ('f' lines): not a triangle mesh");
  return mesh;
}

TriangleMesh parse_stl(std::string_view bytes, const std::string& name) {
  TriangleMesh mesh;
  Welder weld(mesh);
  auto u32 = [&](std::size_t at) {
    return static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at])) |
           static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at + 1])) << 8 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at + 2])) << 16 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at + 3])) << 24;
  };
  // Binary: an 80-byte header, a triangle count, 50 bytes per triangle (normal, 3 corners as
  // little-endian float32, 2 attribute bytes). Some binary files start with "solid" too, so the
  // size decides first.
  if (bytes.size() >= 84 && bytes.size() == 84 + 50 * static_cast<std::uint64_t>(u32(80))) {
    const std::uint32_t n = u32(80);
    for (std::uint32_t t = 0; t < n; ++t) {
      std::array<Index, 3> tri{};
      for (int c = 0; c < 3; ++c) {
        Vec3 p;
        for (int d = 0; d < 3; ++d) {
          p[d] =
              static_cast<double>(std::bit_cast<float>(u32(84 + 50 * std::size_t{t} + 12 + 12 * c + 4 * d)));
          if (!std::isfinite(p[d]))
            malformed(name, 0, "triangle " + std::to_string(t) + " has a non-finite coordinate");
        }
        tri[c] = weld.add(p);
      }
      if (degenerate(tri)) malformed(name, 0, "triangle " + std::to_string(t) + " has two identical corners");
      mesh.triangles.push_back(tri);
    }
    if (mesh.triangles.empty()) malformed(name, 0, "binary STL with no triangles");
    return mesh;
  }
  // ASCII: solid NAME { facet normal n n n  outer loop  vertex x y z (x3)  endloop  endfacet } endsolid
  std::size_t pos = 0, line = 1;
  auto next = [&]() -> std::string_view {
    while (pos < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[pos])))
      line += bytes[pos++] == '\n';
    const std::size_t start = pos;
    while (pos < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[pos]))) ++pos;
    return bytes.substr(start, pos - start);
  };
  auto skip_line = [&] {
    while (pos < bytes.size() && bytes[pos] != '\n') ++pos;
  };
  auto expect = [&](std::string_view word) {
    const std::string_view t = next();
    if (t != word)
      malformed(
          name, line,
          "expected '" + std::string(word) + "', got " + (t.empty() ? "the end of the file" : quoted(t)));
  };
  auto number = [&] {
    const std::string_view t = next();
    double v;
    if (!parse_double(t, v))
      malformed(name, line,
                "expected a finite number, got " + (t.empty() ? "the end of the file" : quoted(t)));
    return v;
  };
  std::string_view t = next();
  if (t != "solid")
    malformed(name, 0,
              "neither binary STL (" + std::to_string(bytes.size()) +
                  " bytes is not 84 + 50 x the triangle count in its header) nor ASCII STL (does not start "
                  "with 'solid')");
  while (t == "solid") {
    skip_line();  // the solid's name
    for (t = next(); t == "facet"; t = next()) {
      const std::size_t facet_line = line;
      expect("normal");
      for (int d = 0; d < 3; ++d) number();
      expect("outer");
      expect("loop");
      std::array<Index, 3> tri{};
      for (int c = 0; c < 3; ++c) {
        expect("vertex");
        const double x = number(), y = number(), z = number();
        tri[c] = weld.add(Vec3(x, y, z));
      }
      expect("endloop");
      expect("endfacet");
      if (degenerate(tri)) malformed(name, facet_line, "facet has two identical corners");
      mesh.triangles.push_back(tri);
    }
    if (t != "endsolid")
      malformed(name, line,
                "expected 'facet' or 'endsolid', got " + (t.empty() ? "the end of the file" : quoted(t)));
    skip_line();
    t = next();
  }
  if (!t.empty()) malformed(name, line, "expected 'solid' or the end of the file, got " + quoted(t));
  if (mesh.triangles.empty()) malformed(name, 0, "ASCII STL with no facets");
  return mesh;
}

TriangleMesh parse_mesh(std::string_view bytes, const std::string& name) {
  const std::string ext = lower_extension(name);
  if (ext == ".obj") return parse_obj(bytes, name);
  if (ext == ".stl") return parse_stl(bytes, name);
  throw std::runtime_error(name + ": unknown mesh format '" + ext + "' (accepted: .obj, .stl)");
}

TriangleMesh read_obj(const std::filesystem::path& file) { return parse_obj(read_file(file), file.string()); }
TriangleMesh read_stl(const std::filesystem::path& file) { return parse_stl(read_file(file), file.string()); }
TriangleMesh read_mesh(const std::filesystem::path& file) {
  const std::string ext = lower_extension(file.string());
  if (ext != ".obj" && ext != ".stl")
    throw std::runtime_error(file.string() + ": unknown mesh format '" + ext + "' (accepted: .obj, .stl)");
  return parse_mesh(read_file(file), file.string());
}

void check_closed(const TriangleMesh& mesh, const std::string& name) {
  if (mesh.triangles.empty()) throw std::runtime_error(name + ": the mesh has no triangles");
  const std::size_t nv = mesh.vertices.size();
  std::vector<std::uint64_t> edges;
  edges.reserve(3 * mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    for (Index v : tri)
      if (v >= nv)
        throw std::runtime_error(name + ": triangle " + std::to_string(t) + " refers to a missing vertex");
    if (degenerate(tri))
      throw std::runtime_error(name + ": triangle " + std::to_string(t) + " repeats a vertex");
    for (int e = 0; e < 3; ++e) {
      const Index a = tri[e], b = tri[(e + 1) % 3];
      edges.push_back(static_cast<std::uint64_t>(std::min(a, b)) << 32 | std::max(a, b));
    }
  }
  std::sort(edges.begin(), edges.end());
  std::size_t bad = 0, first_count = 0;
  std::uint64_t first = 0;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i != 2 && bad++ == 0) {
      first = edges[i];
      first_count = j - i;
    }
    i = j;
  }
  if (bad > 0) {
    auto at = [&](std::uint64_t v) {
      const Vec3& p = mesh.vertices[v];
      return "(" + num(p.x()) + ", " + num(p.y()) + ", " + num(p.z()) + ")";
    };
    throw std::runtime_error(name + ": the mesh is not closed: " + std::to_string(bad) +
                             " edge(s) do not belong to exactly two triangles (the edge " + at(first >> 32) +
                             " - " + at(first & 0xffffffffu) + " belongs to " + std::to_string(first_count) +
                             "); a body needs a closed (watertight) surface");
  }
}

// ---------------------------------------------------------------------------------------------
// Voxelisation

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
