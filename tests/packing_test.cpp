// Packings and geometry (packing.hpp): Poisson-disk and random points, bonds within a radius,
// the OBJ/STL readers, the closed-mesh check, voxelisation, and the scene's packing/mesh bodies.
#include "qbond/builders/packing.hpp"

#include <stdexcept>
#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>

#include "qbond/io/files.hpp"
#include "qbond/model/ordering.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/io/scene.hpp"
#include "heuristics/spatial_hash.hpp"

namespace qbond {
namespace {

namespace fs = std::filesystem;
const fs::path kScenes = fs::path(__FILE__).parent_path().parent_path() / "scenes";

fs::path temp_dir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("qbond_packing_test_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

void write(const fs::path& p, std::string_view bytes) {
  std::ofstream out(p, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// Message of the exception `f` throws (fails when it throws none, or another type).
template <class E, class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  }
  ADD_FAILURE() << "no exception";
  return "";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// ------------------------------------------------------------------------------- point packings

PointPacking poisson(Vec3 size, double r, std::uint64_t seed = 1) {
  PointPacking p;
  p.size = size;
  p.min_distance = r;
  p.bond_radius = 1.6 * r;
  p.seed = seed;
  return p;
}

double closest_pair(const std::vector<Vec3>& x) {
  double d = INFINITY;
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::size_t j = i + 1; j < x.size(); ++j) d = std::min(d, (x[i] - x[j]).norm());
  return d;
}

TEST(PoissonDisk, NoTwoPointsCloserThanTheMinimumDistance) {
  for (const Vec3& size : {Vec3(0.3, 0.2, 0.25), Vec3(0.6, 0.4, 0.0)}) {
    const auto x = sample_points(poisson(size, 0.02));
    ASSERT_GT(x.size(), 300u);
    EXPECT_GE(closest_pair(x), 0.02);
    for (const Vec3& p : x) {
      EXPECT_TRUE((p.array() >= 0).all() && (p.array() <= size.array()).all()) << p.transpose();
      if (size.z() == 0) {
        EXPECT_EQ(p.z(), 0.0);  // 2D: in the xy plane
      }
    }
  }
}

// Bridson's sampling with 30 candidates fills 3D space to about 0.576 points per r³ (78% of the
// random-sequential-adsorption jamming limit 0.3841/(π/6) = 0.734) and 2D to about 0.614 per r²
// (88% of 0.5472/(π/4) = 0.697), measured away from the walls; and it leaves almost no hole
// where another point would fit.
TEST(PoissonDisk, FillsTheBoxToTheExpectedDensity) {
  for (bool flat : {false, true}) {
    const double r = flat ? 0.01 : 0.04;
    const auto x = sample_points(poisson(Vec3(1, 1, flat ? 0 : 1), r, 3));
    const int dims = flat ? 2 : 3;
    std::size_t inner = 0;
    for (const Vec3& p : x)
      inner += (p.array().head(dims) >= 0.1).all() && (p.array().head(dims) <= 0.9).all();
    const double density = static_cast<double>(inner) / std::pow(0.8, dims) * std::pow(r, dims);
    EXPECT_NEAR(density, flat ? 0.614 : 0.576, 0.02) << (flat ? "2D" : "3D");
    // Holes: probes in the interior farther than r from every point (room for one more).
    Rng probe{11};
    int holes = 0;
    const int probes = 2000;
    for (int k = 0; k < probes; ++k) {
      const Vec3 q(0.1 + 0.8 * probe.uniform(), 0.1 + 0.8 * probe.uniform(),
                   flat ? 0.0 : 0.1 + 0.8 * probe.uniform());
      holes += std::none_of(x.begin(), x.end(), [&](const Vec3& p) { return (p - q).norm() < r; });
    }
    EXPECT_LT(holes, probes / 100) << "more than 1% of the interior has room for another point";
    EXPECT_LE(static_cast<double>(x.size()), max_points(poisson(Vec3(1, 1, flat ? 0 : 1), r)));
  }
}

TEST(PoissonDisk, SameSeedSamePointsOtherSeedOthers) {
  for (auto kind : {PointPacking::poisson, PointPacking::random}) {
    PointPacking p = poisson(Vec3(0.2, 0.2, 0.2), 0.02, 5);
    p.kind = kind;
    p.count = kind == PointPacking::random ? 300 : 0;
    const auto a = sample_points(p), b = sample_points(p);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i], b[i]);  // bit for bit
    p.seed = 6;
    const auto c = sample_points(p);
    EXPECT_NE(a[1], c[1]);
  }
}

TEST(PoissonDisk, CountCapsThePoints) {
  PointPacking p = poisson(Vec3(0.2, 0.2, 0.2), 0.02);
  p.count = 50;
  EXPECT_EQ(sample_points(p).size(), 50u);
}

TEST(RandomPacking, UniformPointsWithOptionalRejection) {
  PointPacking p;
  p.kind = PointPacking::random;
  p.size = Vec3(1, 2, 3);
  p.count = 4000;
  p.min_distance = 0;
  auto x = sample_points(p);
  ASSERT_EQ(x.size(), 4000u);
  Vec3 mean = Vec3::Zero();
  for (const Vec3& q : x) mean += q / 4000.0;
  EXPECT_LT((mean - Vec3(0.5, 1, 1.5)).norm(), 0.05);  // σ of each mean coordinate < 0.014
  p.count = 500;
  p.min_distance = 0.1;
  x = sample_points(p);
  ASSERT_EQ(x.size(), 500u);
  EXPECT_GE(closest_pair(x), 0.1);
  p.min_distance = 1e-9;  // a grid of cells 1e-9 m would not fit in memory: cells follow the count
  EXPECT_EQ(sample_points(p).size(), 500u);
  p.min_distance = 0.5;  // 500 points 0.5 apart do not fit in 1 x 2 x 3
  EXPECT_TRUE(contains(error_of<std::invalid_argument>([&] { sample_points(p); }), "could place only"));
}

std::vector<std::pair<Index, Index>> brute_pairs(const std::vector<Vec3>& x, double radius) {
  std::vector<std::pair<Index, Index>> out;
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::size_t j = i + 1; j < x.size(); ++j)
      if ((x[i] - x[j]).norm() <= radius) out.emplace_back(static_cast<Index>(i), static_cast<Index>(j));
  return out;
}

TEST(PairsWithinRadius, ExactlyThePairsBruteForceFinds) {
  PointPacking p;
  p.kind = PointPacking::random;
  p.size = Vec3(1, 1, 0.5);
  p.count = 600;
  p.min_distance = 0;
  const auto x = sample_points(p);
  for (double radius : {0.05, 0.13, 0.4}) {
    const auto fast = pairs_within_radius(x, radius);
    EXPECT_EQ(fast, brute_pairs(x, radius)) << radius;  // same pairs, same (sorted) order
  }
  // Ties: a grid at exactly the radius is bonded (at most, not closer than).
  std::vector<Vec3> grid;
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) grid.emplace_back(0.25 * i, 0.25 * j, 0.25 * k);
  EXPECT_EQ(pairs_within_radius(grid, 0.25).size(), 54u);
  EXPECT_EQ(pairs_within_radius(grid, 0.25), brute_pairs(grid, 0.25));
  // A budget of pairs: met exactly is fine, one short is refused.
  EXPECT_EQ(pairs_within_radius(grid, 0.25, 54).size(), 54u);
  EXPECT_THROW(pairs_within_radius(grid, 0.25, 53), std::length_error);
}

// SpatialHash::pairs (contacts, bond formation) against its documented order, by brute force:
// for each i, the 27 cells around its cell by z, y, x, each cell's points j > i by index, those
// closer than the cell size. The order matters: contacts are resolved and bonds formed in it.
// Each of the grid's layouts: the points close together fill a table of the cells they span at
// 2 cm and of the rows at 5.5 mm (more cells than the table takes); two more points 50 m away
// make it hash the rows.
TEST(SpatialHash, FindsThePairsCloserThanACellInScanOrder) {
  Rng rng{11};
  std::vector<Vec3> x;
  for (int k = 0; k < 400; ++k)  // a sparse gas across the origin (negative cells too)
    x.emplace_back(0.2 * rng.uniform() - 0.1, 0.2 * rng.uniform() - 0.1, 0.1 * rng.uniform());
  for (int k = 0; k < 6; ++k)  // a dense lattice, rows of many points, in scrambled order
    for (int j = 0; j < 6; ++j)
      for (int i = 0; i < 12; ++i) x.emplace_back(0.3 + 0.005 * ((7 * i) % 12), 0.005 * j, 0.005 * k);
  std::vector<Vec3> scattered = x;
  scattered.emplace_back(0.1, 25.0, -25.0);
  scattered.emplace_back(0.1, -25.0, 25.0);
  for (const std::vector<Vec3>* points : {&x, &scattered})
    for (double cell : {0.0055, 0.02}) {
      const std::vector<Vec3>& p = *points;
      auto at = [&](const Vec3& q, int a) { return static_cast<std::int64_t>(std::floor(q[a] / cell)); };
      std::vector<std::pair<Index, Index>> brute;
      for (std::size_t i = 0; i < p.size(); ++i)
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx)
              for (std::size_t j = i + 1; j < p.size(); ++j)
                if (at(p[j], 0) == at(p[i], 0) + dx && at(p[j], 1) == at(p[i], 1) + dy &&
                    at(p[j], 2) == at(p[i], 2) + dz && (p[j] - p[i]).squaredNorm() < cell * cell)
                  brute.emplace_back(static_cast<Index>(i), static_cast<Index>(j));
      SpatialHash grid;
      grid.build(p, cell);
      std::vector<std::pair<Index, Index>> fast;
      grid.pairs(p, [&](Index i, Index j) { fast.emplace_back(i, j); });
      ASSERT_GT(brute.size(), 100u) << cell;
      EXPECT_EQ(fast, brute) << cell << " m cells, " << p.size() << " points";
    }
}

TEST(PointPacking, BondsEveryPairWithinTheRadiusAtItsDistance) {
  World w;
  PointPacking p = poisson(Vec3(0.1, 0.1, 0.1), 0.01);
  p.bond_radius = 0.018;
  p.bond.stiffness = 100;
  const auto ids = add_point_packing(w, p, 0);
  const auto x = sample_points(p);
  const auto pairs = pairs_within_radius(x, p.bond_radius);
  ASSERT_EQ(ids.size(), x.size());  // at this radius no Poisson point is isolated
  ASSERT_EQ(w.num_bonds(), pairs.size());
  for (std::size_t b = 0; b < pairs.size(); ++b) {
    EXPECT_EQ(w.state.bonds.i[b], pairs[b].first);
    EXPECT_EQ(w.state.bonds.j[b], pairs[b].second);
    EXPECT_DOUBLE_EQ(w.state.bonds.rest[b], (x[pairs[b].first] - x[pairs[b].second]).norm());
    EXPECT_EQ(w.state.bonds.strength[b], 100.0);
  }
}

TEST(PointPacking, IsolatedPointsAreDroppedKeptOrRefused) {
  PointPacking p;
  p.kind = PointPacking::random;
  p.size = Vec3(1, 1, 1);
  p.count = 200;
  p.min_distance = 0;
  p.bond_radius = 0.12;  // about 1.4 neighbours each: many points have none
  const auto x = sample_points(p);
  std::vector<int> degree(x.size(), 0);
  for (const auto& [a, b] : pairs_within_radius(x, p.bond_radius)) ++degree[a], ++degree[b];
  const auto lonely = static_cast<std::size_t>(std::count(degree.begin(), degree.end(), 0));
  ASSERT_GT(lonely, 10u);

  World keep;
  p.isolated = Isolated::keep;
  EXPECT_EQ(add_point_packing(keep, p).size(), 200u);
  World drop;
  p.isolated = Isolated::drop;
  const auto ids = add_point_packing(drop, p);
  EXPECT_EQ(ids.size(), 200u - lonely);
  EXPECT_EQ(drop.num_bonds(), keep.num_bonds());
  std::vector<int> d(drop.num_quanta(), 0);
  for (std::size_t b = 0; b < drop.num_bonds(); ++b) ++d[drop.state.bonds.i[b]], ++d[drop.state.bonds.j[b]];
  EXPECT_EQ(std::count(d.begin(), d.end(), 0), 0);
  World refuse;
  p.isolated = Isolated::error;
  EXPECT_TRUE(contains(error_of<std::invalid_argument>([&] { add_point_packing(refuse, p); }),
                       std::to_string(lonely) + " of 200 points have no bond"));
}

// ------------------------------------------------------------------------------------- readers

TEST(MeshReaders, ObjWithSlashesNegativeIndicesQuadsAndComments) {
  const fs::path d = temp_dir("obj");
  // A unit cube: 8 vertices, 6 quad faces written in every OBJ reference form.
  write(d / "cube.obj",
        "# a cube\r\n"
        "mtllib cube.mtl\r\n"
        "o cube\r\n"
        "v 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\n"
        "v 0 0 1\r\nv 1 0 1\r\nv 1 1 1\r\nv 0 1 1 1.0  # w\r\n"
        "vt 0 0\r\nvn 0 0 1\r\n"
        "f 1 4 3 2\r\n"
        "f 5/1 6/1 7/1 8/1\r\n"
        "f 1//1 2//1 6//1 5//1\n"
        "f 2/1/1 3/1/1 7/1/1 6/1/1\n"
        "f -5 -1 -2 -6\n"  // 4 8 7 3 (relative to the 8 vertices so far)
        "f 4 8 5 1\n");
  const TriangleMesh m = read_obj(d / "cube.obj");
  ASSERT_EQ(m.vertices.size(), 8u);
  ASSERT_EQ(m.triangles.size(), 12u);
  EXPECT_EQ(m.vertices[6], Vec3(1, 1, 1));
  EXPECT_EQ(m.triangles[0], (std::array<Index, 3>{0, 3, 2}));  // fan of the quad 1 4 3 2
  EXPECT_EQ(m.triangles[1], (std::array<Index, 3>{0, 2, 1}));
  EXPECT_EQ(m.triangles[8], (std::array<Index, 3>{3, 7, 6}));  // f -5 -1 -2 -6
  EXPECT_NO_THROW(check_closed(m, "cube"));
  EXPECT_EQ(read_mesh(d / "cube.obj").triangles, m.triangles);
  fs::remove_all(d);
}

TEST(MeshReaders, ObjErrorsNameTheLineAndTheRule) {
  const std::pair<const char*, const char*> cases[] = {
      {"v 0 0 0\nv 1 0\n", "x.obj:2: a vertex needs 3 coordinates"},
      {"v 0 0 0\nv 1 0 zero\n", "x.obj:2: vertex coordinate 'zero' is not a finite number"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
       "x.obj:4: face vertex 4 does not exist (3 vertices defined so far)"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", "x.obj:4: face vertex -4 does not exist"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "x.obj:4: face vertex '0' is not a non-zero integer"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "x.obj:4: a face needs at least 3 vertices"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2\n", "x.obj:4: face uses vertex 2 twice"},
      {"v 0 0 0\n", "x.obj: no faces"},
  };
  for (const auto& [text, message] : cases) {
    const std::string& obj = text;  // clang before 16 captures no structured binding
    const std::string e = error_of<std::runtime_error>([&] { parse_obj(obj, "x.obj"); });
    EXPECT_TRUE(contains(e, message)) << e << "\nexpected: " << message;
  }
}

// A closed unit cube as 12 triangles (outward).
TriangleMesh unit_cube(double side = 1) {
  TriangleMesh m;
  for (int k = 0; k < 8; ++k) m.vertices.push_back(side * Vec3(k & 1, (k >> 1) & 1, (k >> 2) & 1));
  m.triangles = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
                 {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  return m;
}

std::string ascii_stl(const TriangleMesh& m) {
  std::string s = "solid cube exported\n";
  for (const auto& t : m.triangles) {
    s += "  facet normal 0 0 0\n    outer loop\n";
    for (Index v : t) {
      char line[128];
      std::snprintf(line, sizeof line, "      vertex %.17g %.17g %.17g\n", m.vertices[v].x(),
                    m.vertices[v].y(), m.vertices[v].z());
      s += line;
    }
    s += "    endloop\n  endfacet\n";
  }
  return s + "endsolid cube exported\n";
}

std::string binary_stl(const TriangleMesh& m, const std::string& header) {
  std::string s = header;
  s.resize(80, ' ');
  auto u32 = [&](std::uint32_t v) {
    for (int b = 0; b < 4; ++b) s.push_back(static_cast<char>((v >> (8 * b)) & 0xff));
  };
  u32(static_cast<std::uint32_t>(m.triangles.size()));
  for (const auto& t : m.triangles) {
    for (int k = 0; k < 3; ++k) u32(0);  // normal
    for (Index v : t)
      for (int d = 0; d < 3; ++d) u32(std::bit_cast<std::uint32_t>(static_cast<float>(m.vertices[v][d])));
    s += std::string(2, '\0');
  }
  return s;
}

TEST(MeshReaders, AsciiAndBinaryStlWeldTheCornersBackIntoACube) {
  const fs::path d = temp_dir("stl");
  const TriangleMesh cube = unit_cube(0.5);
  write(d / "ascii.stl", ascii_stl(cube));
  write(d / "binary.STL", binary_stl(cube, "solid but binary: the size decides"));
  for (const char* name : {"ascii.stl", "binary.STL"}) {
    const TriangleMesh m = read_mesh(d / name);
    EXPECT_EQ(m.vertices.size(), 8u) << name;
    ASSERT_EQ(m.triangles.size(), 12u) << name;
    for (std::size_t t = 0; t < 12; ++t)
      for (int c = 0; c < 3; ++c)
        EXPECT_EQ(m.vertices[m.triangles[t][c]], cube.vertices[cube.triangles[t][c]]);
    EXPECT_NO_THROW(check_closed(m, name));
  }
  fs::remove_all(d);
}

TEST(MeshReaders, StlErrorsNameTheRule) {
  const std::string good = ascii_stl(unit_cube());
  std::string truncated = binary_stl(unit_cube(), "");
  truncated.resize(truncated.size() - 7);
  std::string typo = good;
  const std::size_t at = typo.find("endloop", 200);
  typo.replace(at, 7, "endlop");
  const std::string typo_line =
      "x.stl:" +
      std::to_string(std::count(typo.begin(), typo.begin() + static_cast<std::ptrdiff_t>(at), '\n') + 1);
  std::string bad_number = good;
  bad_number.replace(bad_number.find("vertex 0 0 0"), 12, "vertex 0 x 0");
  const std::pair<std::string, std::string> cases[] = {
      {truncated, "x.stl: neither binary STL (677 bytes is not 84 + 50 x the triangle count"},
      {"hello", "x.stl: neither binary STL"},
      {typo, typo_line + ": expected 'endloop', got 'endlop'"},
      {bad_number, "x.stl:4: expected a finite number, got 'x'"},
      {good.substr(0, good.size() - 40), "x.stl:"},
      {"solid empty\nendsolid empty\n", "x.stl: ASCII STL with no facets"},
  };
  for (const auto& [bytes, message] : cases) {
    const std::string& stl = bytes;  // clang before 16 captures no structured binding
    const std::string e = error_of<std::runtime_error>([&] { parse_stl(stl, "x.stl"); });
    EXPECT_TRUE(contains(e, message)) << e << "\nexpected: " << message;
  }
  EXPECT_TRUE(contains(error_of<std::runtime_error>([] { read_mesh("nowhere/x.ply"); }),
                       "unknown mesh format '.ply'"));
  EXPECT_TRUE(contains(error_of<std::runtime_error>([] { read_mesh("nowhere/x.obj"); }), "cannot read"));
}

TEST(ClosedMesh, EveryEdgeInExactlyTwoTriangles) {
  TriangleMesh open = unit_cube();
  open.triangles.pop_back();
  const std::string e = error_of<std::runtime_error>([&] { check_closed(open, "box"); });
  EXPECT_TRUE(contains(e, "box: the mesh is not closed: 3 edge(s) do not belong to exactly two triangles"))
      << e;
  TriangleMesh fin = unit_cube();
  fin.vertices.emplace_back(2, 0, 0);
  fin.triangles.push_back({0, 1, 8});  // a fin on the edge 0-1: three triangles share it
  EXPECT_TRUE(contains(error_of<std::runtime_error>([&] { check_closed(fin, "fin"); }), "belongs to 3"));
  TriangleMesh degenerate = unit_cube();
  degenerate.triangles[0] = {0, 0, 3};
  EXPECT_TRUE(
      contains(error_of<std::runtime_error>([&] { check_closed(degenerate, "d"); }), "repeats a vertex"));
  World w;
  MeshLattice m;
  m.mesh = open;
  EXPECT_THROW(add_mesh_lattice(w, m), std::runtime_error);
}

// -------------------------------------------------------------------------------- voxelisation

TEST(MeshLattice, UnitCubeAtSpacingATenthHasExactlyAThousandSites) {
  World w;
  MeshLattice m;
  m.mesh = unit_cube();
  m.spacing = 0.1;
  m.shells = Shells::body_diagonal;
  const auto ids = add_mesh_lattice(w, m);
  EXPECT_EQ(ids.size(), 1000u);  // cell centres 0.05 .. 0.95; rows along the faces' diagonals
  // The same quanta and bonds, in the same order, as the cubic lattice of the cube's cells.
  World ref;
  CubicLattice c;
  c.size = {10, 10, 10};
  c.spacing = 0.1;
  c.origin = Vec3::Constant(0.05);
  c.shells = Shells::body_diagonal;
  add_cubic_lattice(ref, c);
  ASSERT_EQ(w.num_quanta(), ref.num_quanta());
  for (std::size_t i = 0; i < w.num_quanta(); ++i) EXPECT_LT((w.state.x[i] - ref.state.x[i]).norm(), 1e-12);
  ASSERT_EQ(w.num_bonds(), ref.num_bonds());
  for (std::size_t b = 0; b < w.num_bonds(); ++b) {
    EXPECT_EQ(w.state.bonds.i[b], ref.state.bonds.i[b]);
    EXPECT_EQ(w.state.bonds.j[b], ref.state.bonds.j[b]);
  }
  // A box that is not a whole number of cells: the grid is centred, cells cover the box.
  m.mesh = unit_cube();
  for (Vec3& v : m.mesh.vertices) v = v.cwiseProduct(Vec3(0.55, 0.3, 0.2));
  const MeshGrid g = mesh_grid(m);
  EXPECT_EQ(g.cells, (std::array<std::int64_t, 3>{6, 3, 2}));
  EXPECT_NEAR(g.first.x(), 0.275 - 2.5 * 0.1, 1e-15);
  World box;
  EXPECT_EQ(add_mesh_lattice(box, m).size(), 6u * 3 * 2);  // x = 0.025 .. 0.525, all inside
}

// An octahedron |x| + |y| + |z| <= 1 with grid rows through its vertices and along its edges
// (y = 0 or z = 0): each ray must cross the surface once per sheet, never 0 or 2 times.
TEST(MeshLattice, RaysThroughVerticesAndEdgesCountOnce) {
  TriangleMesh o;
  o.vertices = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  o.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  check_closed(o, "octahedron");
  MeshGrid g;
  g.cells = {20, 21, 21};  // x = ±0.05, ±0.15, ...; y, z = -1, -0.9, ..., 1
  g.first = Vec3(-0.95, -1, -1);
  const auto inside = inside_sites(o, g, 0.1);
  std::size_t count = 0, expected = 0;
  for (auto v : inside) count += v;
  for (int j = -10; j <= 10; ++j)
    for (int k = -10; k <= 10; ++k)
      expected += 2 * static_cast<std::size_t>(std::max(0, 10 - std::abs(j) - std::abs(k)));
  EXPECT_EQ(count, expected);
  // Row by row, too: the row through y = z = 0 (two vertices on it) has 20 sites inside.
  std::size_t row = 0;
  for (int i = 0; i < 20; ++i) row += inside[static_cast<std::size_t>((10 * 21 + 10) * 20 + i)];
  EXPECT_EQ(row, 20u);
}

TriangleMesh sphere(int levels, double radius) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  TriangleMesh m;
  m.vertices = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (Vec3& v : m.vertices) v.normalize();
  m.triangles = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                 {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<Index, Index>, Index> mid;
    auto midpoint = [&](Index a, Index b) {
      const auto key = std::minmax(a, b);
      if (auto it = mid.find(key); it != mid.end()) return it->second;
      m.vertices.push_back((m.vertices[a] + m.vertices[b]).normalized());
      return mid[key] = static_cast<Index>(m.vertices.size() - 1);
    };
    std::vector<std::array<Index, 3>> next;
    for (const auto& [a, b, c] : m.triangles) {
      const Index ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      next.insert(next.end(), {{a, ab, ca}, {b, bc, ab}, {c, ca, bc}, {ab, bc, ca}});
    }
    m.triangles = std::move(next);
  }
  for (Vec3& v : m.vertices) v *= radius;
  return m;
}

// Each site stands for its cell (a³), so the count is the sphere's volume over a³ up to the cells
// the surface cuts: rigorously between the volumes of the spheres of radius r ∓ a√3/2; in
// practice within 2% for r = 10 a.
TEST(MeshLattice, SphereCountIsItsVolumeOverTheCellVolume) {
  const double r = 1, a = 0.1;
  World w;
  MeshLattice m;
  m.mesh = sphere(4, r);  // 5120 triangles, volume within 0.4% of the sphere's
  m.spacing = a;
  const double n = static_cast<double>(add_mesh_lattice(w, m).size());
  const double ideal = 4.0 / 3 * std::numbers::pi * r * r * r / (a * a * a);
  const double slack = std::sqrt(3.0) / 2 * a;
  EXPECT_GT(n, ideal * std::pow((r - slack) / r, 3));
  EXPECT_LT(n, ideal * std::pow((r + slack) / r, 3));
  EXPECT_NEAR(n / ideal, 1, 0.02) << n << " sites, " << ideal << " expected";
  // Symmetric about the centre: the centre of mass of the sites is the sphere's.
  Vec3 cm = Vec3::Zero();
  for (const Vec3& x : w.state.x) cm += x / n;
  EXPECT_LT(cm.norm(), 1e-3);
}

TEST(MeshLattice, TheProjectsTorusFillsItsVolume) {
  const TriangleMesh torus = read_mesh(kScenes / "meshes" / "torus.obj");
  check_closed(torus, "torus.obj");
  World w;
  MeshLattice m;
  m.mesh = torus;
  m.scale = 0.001;  // millimetres
  m.spacing = 0.003;
  const double n = static_cast<double>(add_mesh_lattice(w, m).size());
  // The 32 x 16 polygonal torus has 96.8% of the smooth torus's volume 2π² R r².
  const double ideal =
      0.968 * 2 * std::numbers::pi * std::numbers::pi * 0.040 * 0.015 * 0.015 / std::pow(0.003, 3);
  EXPECT_NEAR(n / ideal, 1, 0.03) << n << " sites";
  for (const Vec3& x : w.state.x) {
    const double ring = std::hypot(x.x(), x.y()) - 0.040;
    // Inside the smooth tube, up to the polygon's chords across the hole (0.12 mm).
    EXPECT_LT(std::hypot(ring, x.z()), 0.0152) << "a site outside the tube";
  }
}

TEST(MeshLattice, TheProjectsMeshesAreClosedAndBuiltIn) {
  std::size_t found = 0;
  for (const char* name : {"torus.obj", "tetrahedron.stl", "blob.stl"}) {
    const fs::path file = kScenes / "meshes" / name;
    EXPECT_NO_THROW(check_closed(read_mesh(file), name));
    for (const BuiltinFile& f : builtin_files())
      if (f.path == std::string("meshes/") + name) {
        ++found;
        EXPECT_EQ(f.data, read_file(file)) << name << ": the built-in copy differs from the file";
      }
  }
  EXPECT_EQ(found, 3u);
}

// -------------------------------------------------------------------------------------- scenes

const char* kPackingScene = R"({
  "timestep": 0.001, "steps": 10, "seed": 4,
  "materials": {"m": {"stiffness": 100}},
  "bodies": [
    {"name": "block", "type": "packing", "points": "poisson", "size": [0.1, 0.05, 0.05], "min_distance": 0.01,
     "bond_radius": 0.017, "material": "m", "total_mass": 0.2, "origin": [0, 0, 1]},
    {"name": "flat", "type": "packing", "points": "random", "size": [0.1, 0.1, 0], "count": 40,
     "min_distance": 0.005, "bond_radius": 0.04, "isolated": "keep", "seed": 9, "material": "m", "quanta_mass": 0.01}
  ]
})";

TEST(PackingScene, BuildsThePackingAndItsResolvedSceneRebuildsIt) {
  const Scene s = parse_scene(kPackingScene);
  const World& w = s.world;
  PointPacking p = poisson(Vec3(0.1, 0.05, 0.05), 0.01, 4);  // the scene's seed
  const auto x = sample_points(p);
  std::size_t block = 0, mass_sum_ok = 0;
  for (std::size_t i = 0; i < w.num_quanta(); ++i) block += w.model.body[i] == 0;
  ASSERT_EQ(block, x.size());
  const std::vector<Index> at = quanta_by_id(w.model);  // the block's quanta are ids 0..block-1
  for (std::size_t k = 0; k < block; ++k) {
    EXPECT_EQ(w.state.x[at[k]], x[k] + Vec3(0, 0, 1));
    mass_sum_ok += std::abs(w.model.mass[at[k]] - 0.2 / static_cast<double>(block)) < 1e-15;
  }
  EXPECT_EQ(mass_sum_ok, block);
  EXPECT_EQ(w.num_quanta() - block, 40u);  // "keep": all 40 random points
  const nlohmann::json& r = s.resolved["bodies"];
  EXPECT_EQ(r[0]["seed"], 4);
  EXPECT_EQ(r[0]["isolated"], "drop");
  EXPECT_EQ(r[0]["count"], 0);
  EXPECT_EQ(r[1]["seed"], 9);
  const Scene again = parse_scene(s.resolved.dump());
  ASSERT_EQ(again.world.num_quanta(), w.num_quanta());
  ASSERT_EQ(again.world.num_bonds(), w.num_bonds());
  for (std::size_t i = 0; i < w.num_quanta(); ++i) EXPECT_EQ(again.world.state.x[i], w.state.x[i]);
  for (std::size_t b = 0; b < w.num_bonds(); ++b) EXPECT_EQ(again.world.state.bonds.rest[b], w.state.bonds.rest[b]);
}

TEST(MeshScene, FileIsRelativeToTheSceneAndResolvedToAnAbsolutePath) {
  const fs::path d = temp_dir("scene");
  fs::create_directories(d / "shapes");
  write(d / "shapes" / "cube.stl", binary_stl(unit_cube(0.1), "cube"));
  write(d / "drop.json", R"({
    "timestep": 0.001, "steps": 10,
    "materials": {"m": {"stiffness": 100}},
    "bodies": [{"name": "cube", "type": "mesh", "file": "shapes/cube.stl", "spacing": 0.01,
                "neighbors": "nearest", "material": "m", "total_mass": 1}]
  })");
  const Scene s = load_scene(d / "drop.json");
  EXPECT_EQ(s.world.num_quanta(), 1000u);
  EXPECT_EQ(s.world.num_bonds(), 3u * 10 * 10 * 9);
  EXPECT_DOUBLE_EQ(s.world.model.mass[0], 1e-3);
  const std::string file = s.resolved["bodies"][0]["file"];
  EXPECT_EQ(fs::path(file), fs::absolute(d / "shapes" / "cube.stl").lexically_normal());
  EXPECT_EQ(s.resolved["bodies"][0]["scale"], 1.0);
  EXPECT_EQ(s.resolved["bodies"][0]["neighbors"], "nearest");
  // The resolved scene (what run.json and checkpoints keep) loads from anywhere.
  EXPECT_EQ(parse_scene(s.resolved.dump()).world.num_bonds(), s.world.num_bonds());
  // From a string, relative paths are relative to the current directory: not found here.
  const std::string text = read_file(d / "drop.json");
  const std::string e = error_of<SceneError>([&] { parse_scene(text, "drop"); });
  EXPECT_TRUE(contains(e, "bodies[0].file: cannot read 'shapes/cube.stl': no such file (looked for ")) << e;
  fs::remove_all(d);
}

TEST(MeshScene, BuiltInScenesReadTheBuiltInMeshes) {
  const Scene s = builtin_scene("mesh_drop");
  EXPECT_GT(s.world.num_quanta(), 100u);
  bool mesh = false;
  for (const auto& b : s.resolved["bodies"])
    if (b["type"] == "mesh") {
      mesh = true;
      EXPECT_TRUE(b["file"].get<std::string>().starts_with("builtin:meshes/")) << b["file"];
    }
  EXPECT_TRUE(mesh);
  // The resolved scene names the built-in file, so a resumed run finds it from anywhere.
  EXPECT_EQ(parse_scene(s.resolved.dump()).world.num_quanta(), s.world.num_quanta());
  // And the same scene from its file reads scenes/meshes/ on disk: the same world.
  const Scene f = load_scene(kScenes / "mesh_drop.json");
  ASSERT_EQ(f.world.num_quanta(), s.world.num_quanta());
  for (std::size_t i = 0; i < s.world.num_quanta(); ++i) EXPECT_EQ(f.world.state.x[i], s.world.state.x[i]);
  const std::string e = error_of<SceneError>([] {
    parse_scene(R"({"timestep": 1, "steps": 1, "materials": {"m": {"stiffness": 1}},
      "bodies": [{"name": "b", "type": "mesh", "file": "builtin:meshes/cow.obj", "spacing": 0.01,
                  "material": "m", "quanta_mass": 1}]})");
  });
  EXPECT_TRUE(
      contains(e, "bodies[0].file: no built-in file 'meshes/cow.obj' (built-in files, from scenes/: "))
      << e;
}

}  // namespace
}  // namespace qbond
