// Other programs' files as bodies and outputs: tetrahedral meshes (Gmsh 2.2/4.1, VTK .vtu), CSV
// tables of quanta and bonds, and LAMMPS data files (read, and written so that they read back
// bit for bit).
#include <gtest/gtest.h>

#include <bit>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <set>
#include <sstream>
#include <unistd.h>

#include "qbond/builders/csv_table.hpp"
#include "qbond/builders/tet_mesh.hpp"
#include "qbond/io/files.hpp"
#include "qbond/io/lammps_data.hpp"
#include "qbond/io/scene.hpp"

using namespace qbond;

namespace {

const std::filesystem::path kSource = QBOND_SOURCE_DIR;

template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

/// The unique triangles of a tetrahedral mesh (for Euler's formula).
std::size_t unique_faces(const TetMesh& m) {
  std::set<std::array<Index, 3>> faces;
  for (const auto& t : m.tets)
    for (std::size_t skip = 0; skip < 4; ++skip) {
      std::array<Index, 3> f{};
      std::size_t k = 0;
      for (std::size_t c = 0; c < 4; ++c)
        if (c != skip) f[k++] = t[c];
      std::sort(f.begin(), f.end());
      faces.insert(f);
    }
  return faces.size();
}

std::filesystem::path temp_dir(const std::string& name) {
  const auto d = std::filesystem::temp_directory_path() / ("qbond_file_formats_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(d);
  return d;
}

void write(const std::filesystem::path& p, const std::string& text) {
  std::ofstream(p) << text;
}

}  // namespace

// ---- Tetrahedral meshes -----------------------------------------------------------------------

// The example bar: 8 × 2 × 2 cubes of 1 cm, each cut into the 6 Kuhn tetrahedra. Its counts
// follow from the grid: V = 9·3·3 nodes; edges = the grid's axis edges, one diagonal per square
// face and one per cube; T = 6 per cube; and the triangulated ball has Euler characteristic
// V − E + F − T = 1.
TEST(TetMesh, BarCountsFollowTheGridAndEuler) {
  const int a = 8, b = 2, c = 2;
  const std::size_t V = (a + 1) * (b + 1) * (c + 1);
  const std::size_t axis = a * (b + 1) * (c + 1) + (a + 1) * b * (c + 1) + (a + 1) * (b + 1) * c;
  const std::size_t face_diagonals = a * b * (c + 1) + a * (b + 1) * c + (a + 1) * b * c;
  const std::size_t E = axis + face_diagonals + a * b * c;
  for (const char* file : {"bar.msh", "bar_v41.msh", "bar.vtu"}) {
    SCOPED_TRACE(file);
    const TetMesh m = read_tet_mesh(kSource / "scenes/meshes" / file);
    EXPECT_EQ(m.nodes.size(), V);
    EXPECT_EQ(m.tets.size(), std::size_t{6} * a * b * c);
    const auto edges = tet_edges(m);
    EXPECT_EQ(edges.size(), E);
    const std::size_t F = unique_faces(m);
    EXPECT_EQ(static_cast<long>(V) - static_cast<long>(E) + static_cast<long>(F) - static_cast<long>(m.tets.size()), 1);
    // Lumped volumes sum to the bar's volume (8 × 2 × 2 cm³) to rounding: 192 tetrahedra, 81
    // nodes, each volume, quarter and sum rounding once (≤ 200 roundings of 1.1e-16).
    const auto vol = lumped_volumes(m);
    EXPECT_NEAR(std::accumulate(vol.begin(), vol.end(), 0.0), a * b * c * 1e-6, a * b * c * 1e-6 * 200 * 1.2e-16);
  }
  // The three files hold the same mesh.
  const TetMesh g2 = read_tet_mesh(kSource / "scenes/meshes/bar.msh");
  const TetMesh g4 = read_tet_mesh(kSource / "scenes/meshes/bar_v41.msh");
  const TetMesh vt = read_tet_mesh(kSource / "scenes/meshes/bar.vtu");
  EXPECT_EQ(g2.nodes, g4.nodes);
  EXPECT_EQ(g2.nodes, vt.nodes);
  EXPECT_EQ(g2.tets, g4.tets);
  EXPECT_EQ(g2.tets, vt.tets);
}

// Gmsh's own output (tests/meshes/cube.geo meshed by Gmsh 4.8 in both formats, with physical
// groups, entities and boundary triangles): the same mesh from either, a triangulated ball
// (V − E + F − T = 1) of volume 1.
TEST(TetMesh, ReadsWhatGmshWrites) {
  const TetMesh a = read_tet_mesh(kSource / "tests/meshes/cube_gmsh22.msh");
  const TetMesh b = read_tet_mesh(kSource / "tests/meshes/cube_gmsh41.msh");
  EXPECT_EQ(a.nodes, b.nodes);
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_GT(a.tets.size(), 20u);
  const long V = static_cast<long>(a.nodes.size()), E = static_cast<long>(tet_edges(a).size()),
             F = static_cast<long>(unique_faces(a)), T = static_cast<long>(a.tets.size());
  EXPECT_EQ(V - E + F - T, 1);
  const auto vol = lumped_volumes(a);
  EXPECT_NEAR(std::accumulate(vol.begin(), vol.end(), 0.0), 1.0, 1e-12);
}

TEST(TetMesh, SingleTetrahedronVolumeAndLumping) {
  const std::string msh =
      "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n3 1 \"solid\"\n$EndPhysicalNames\n"
      "$Nodes\n5\n10 0 0 0\n20 2 0 0\n30 0 3 0\n40 0 0 4\n50 9 9 9\n$EndNodes\n"
      "$Elements\n3\n1 15 2 0 1 50\n2 2 2 0 1 10 20 30\n3 4 2 1 1 10 20 30 40\n$EndElements\n";
  const TetMesh m = parse_tet_mesh(msh, "one.msh");
  ASSERT_EQ(m.nodes.size(), 4u);  // node 50 (a geometry point) is left out
  ASSERT_EQ(m.tets.size(), 1u);
  EXPECT_EQ(tet_edges(m).size(), 6u);
  for (double v : lumped_volumes(m)) EXPECT_EQ(v, 4.0 / 4);  // V = 2·3·4/6 = 4
}

TEST(TetMesh, BadFilesNameFileAndLine) {
  auto err = [](const std::string& text, const std::string& name) {
    return error_of([&] { parse_tet_mesh(text, name); });
  };
  const std::string head = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
  EXPECT_PRED2(contains, err(head + "$Nodes\n1\n1 0 0 zero\n$EndNodes\n", "a.msh"), "a.msh:6: coordinate 'zero'");
  EXPECT_PRED2(contains, err("$MeshFormat\n2.2 1 8\n$EndMeshFormat\n", "b.msh"), "b.msh:2: binary Gmsh files");
  EXPECT_PRED2(contains, err("$MeshFormat\n3.0 0 8\n$EndMeshFormat\n", "c.msh"), "c.msh:2: Gmsh format version '3.0'");
  const std::string nodes = head + "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n";
  EXPECT_PRED2(contains, err(nodes + "$Elements\n1\n1 4 0 1 2 3 9\n$EndElements\n", "d.msh"),
                       "d.msh:13: tetrahedron node 9 is not in $Nodes");
  EXPECT_PRED2(contains, err(nodes + "$Elements\n1\n1 11 0 1 2 3 4 1 2 3 4 1 2\n$EndElements\n", "e.msh"),
                       "e.msh:13: element type 11 is a volume element");
  EXPECT_PRED2(contains, err(nodes + "$Elements\n1\n1 4 0 1 2 3 3\n$EndElements\n", "f.msh"),
                       "f.msh:13: tetrahedron 0 names a node twice");
  const std::string flat = head + "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 1 1 0\n$EndNodes\n";
  EXPECT_PRED2(contains, err(flat + "$Elements\n1\n1 4 0 1 2 3 4\n$EndElements\n", "g.msh"), "g.msh:13: tetrahedron 0 has zero volume");
  EXPECT_PRED2(contains, err(nodes + "$Elements\n2\n1 4 0 1 2 3 4\n", "h.msh"), "h.msh:13: the file ends where");
  EXPECT_PRED2(contains, err(nodes + "$Elements\n1\n1 2 0 1 2 3\n$EndElements\n", "i.msh"), "i.msh: no four-node tetrahedra");
  EXPECT_PRED2(contains, err("hello", "j.msh"), "j.msh:1: expected a section");
  EXPECT_PRED2(contains, err("", "k.msh"), "k.msh: no $MeshFormat");
  EXPECT_PRED2(contains, err("x", "l.ply"), "unknown tetrahedral mesh format '.ply'");
  // 4.1: the header's counts must match the blocks.
  EXPECT_PRED2(contains, err("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 2 1 2\n3 1 0 1\n1\n0 0 0\n$EndNodes\n", "m.msh"),
                       "m.msh:8: the node blocks hold 1 nodes, the header says 2");

  const std::string vtu_head =
      "<VTKFile type=\"UnstructuredGrid\">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">\n"
      "<Points>\n<DataArray NumberOfComponents=\"3\" format=\"ascii\">\n0 0 0 1 0 0 0 1 0 0 0 1\n</DataArray>\n</Points>\n"
      "<Cells>\n";
  auto cells = [&](const std::string& conn, const std::string& type, const std::string& format = "ascii") {
    return vtu_head + "<DataArray Name=\"connectivity\" format=\"" + format + "\">\n" + conn +
           "\n</DataArray>\n<DataArray Name=\"offsets\" format=\"ascii\">4</DataArray>\n"
           "<DataArray Name=\"types\" format=\"ascii\">" + type + "</DataArray>\n</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
  };
  EXPECT_EQ(parse_tet_mesh(cells("0 1 2 3", "10"), "ok.vtu").tets.size(), 1u);
  EXPECT_PRED2(contains, err(cells("0 1 2 7", "10"), "a.vtu"), "a.vtu:10: cell 0 names point 7");
  EXPECT_PRED2(contains, err(cells("0 1 2 x", "10"), "b.vtu"), "b.vtu:11: connectivity value 'x'");
  EXPECT_PRED2(contains, err(cells("0 1 2 3", "12"), "c.vtu"), "c.vtu:14: cell 0 has VTK type 12");
  EXPECT_PRED2(contains, err(cells("0 1 2 3", "10", "binary"), "d.vtu"), "d.vtu:10: connectivity's DataArray has format 'binary'");
  EXPECT_PRED2(contains, err("<VTKFile type=\"PolyData\">", "e.vtu"), "e.vtu: no <UnstructuredGrid>");
}

TEST(TetMesh, BodyMassIsDensityTimesVolumeAndBondsAreEdges) {
  const std::string scene = R"({
    "timestep": 0.001, "steps": 1,
    "materials": {"steel": {"stiffness": 1e5, "density": 7800}},
    "bodies": [{"name": "bar", "type": "tet_mesh", "file": ")" + (kSource / "scenes/meshes/bar.msh").string() + R"(",
                "material": "steel", "scale": 2}]})";
  const Scene s = parse_scene(scene);
  const TetMesh m = read_tet_mesh(kSource / "scenes/meshes/bar.msh");
  ASSERT_EQ(s.world.num_quanta(), m.nodes.size());
  EXPECT_EQ(s.world.num_bonds(), tet_edges(m).size());
  const double volume = 8 * 2 * 2 * 1e-6 * 8;  // scale 2: × 2³
  const double mass = std::accumulate(s.world.model.mass.begin(), s.world.model.mass.end(), 0.0);
  // Σ ρ V_i over 81 nodes: each term and each addition rounds once.
  EXPECT_NEAR(mass, 7800 * volume, 7800 * volume * 200 * 1.2e-16);
  const double vsum = std::accumulate(s.world.model.volume.begin(), s.world.model.volume.end(), 0.0);
  EXPECT_NEAR(vsum, volume, volume * 200 * 1.2e-16);
  // A total mass instead of a density: spread by the nodes' volumes.
  const std::string by_total = R"({
    "timestep": 0.001, "steps": 1, "materials": {"k": {"stiffness": 1e5}},
    "bodies": [{"name": "bar", "type": "tet_mesh", "file": ")" + (kSource / "scenes/meshes/bar.vtu").string() + R"(",
                "material": "k", "total_mass": 3}]})";
  const Scene t = parse_scene(by_total);
  EXPECT_NEAR(std::accumulate(t.world.model.mass.begin(), t.world.model.mass.end(), 0.0), 3, 3 * 200 * 1.2e-16);
  // Errors at the body's keys.
  const std::string bad = R"({
    "timestep": 0.001, "steps": 1, "materials": {"k": {"stiffness": 1e5}},
    "bodies": [{"name": "bar", "type": "tet_mesh", "file": "nowhere.msh", "material": "k"}]})";
  EXPECT_PRED2(contains, error_of([&] { parse_scene(bad); }), "bodies[0]: the mass needs a material with a 'density'");
}

// ---- CSV --------------------------------------------------------------------------------------

TEST(CsvTable, HeaderOrNotAndErrors) {
  const CsvQuanta a = parse_quanta_csv("# a comment\nz, x ,y,mass\n3,1,2,0.5\n\n6,4,5,0.25\n", "q.csv");
  ASSERT_EQ(a.x.size(), 2u);
  EXPECT_EQ(a.x[0], Vec3(1, 2, 3));
  EXPECT_EQ(a.x[1], Vec3(4, 5, 6));
  EXPECT_EQ(a.mass, (std::vector<double>{0.5, 0.25}));
  EXPECT_TRUE(a.v.empty());
  const CsvQuanta b = parse_quanta_csv("1,2,3,0.1,0.2,0.3\r\n4,5,6,-1,-2,-3\r\n", "q.csv");
  EXPECT_TRUE(b.mass.empty());
  EXPECT_EQ(b.v[1], Vec3(-1, -2, -3));
  auto qerr = [](const std::string& t) { return error_of([&] { parse_quanta_csv(t, "q.csv"); }); };
  EXPECT_PRED2(contains, qerr("x,y,w\n1,2,3\n"), "q.csv:1: unknown column 'w'");
  EXPECT_PRED2(contains, qerr("x,y\n1,2\n"), "q.csv:1: the header has no column 'z'");
  EXPECT_PRED2(contains, qerr("1,2,3\n4,5\n"), "q.csv:2: has 2 fields, the table's rows have 3");
  EXPECT_PRED2(contains, qerr("1,2,3,4,5\n"), "q.csv:1: a row without a header has 5 fields");
  EXPECT_PRED2(contains, qerr("x,y,z,mass\n1,2,3,0\n"), "q.csv:2: column mass: must be > 0");
  EXPECT_PRED2(contains, qerr("x,y,z\n1,2,nan\n"), "q.csv:2: column z: 'nan' is not a finite number");
  EXPECT_PRED2(contains, qerr("x,y,z,vx\n1,2,3,4\n"), "give all three velocity columns");
  EXPECT_PRED2(contains, qerr("# nothing\n"), "q.csv: no rows");

  const CsvBonds c = parse_bonds_csv("i,j,material\n0,1,steel\n2,1,rubber\n", "b.csv", 3);
  EXPECT_EQ(c.ends, (std::vector<std::pair<Index, Index>>{{0, 1}, {2, 1}}));
  EXPECT_EQ(c.material, (std::vector<std::string>{"steel", "rubber"}));
  auto berr = [](const std::string& t) { return error_of([&] { parse_bonds_csv(t, "b.csv", 3); }); };
  EXPECT_PRED2(contains, berr("0,3\n"), "b.csv:1: column j: '3' is not a row of the quanta table (0-based, 3 rows)");
  EXPECT_PRED2(contains, berr("0,1\n1,0\n"), "b.csv:2: bonds 1 and 0 a second time");
  EXPECT_PRED2(contains, berr("2,2\n"), "b.csv:1: bonds quanta 2 to itself");
  EXPECT_PRED2(contains, berr("0,1.5\n"), "column j: '1.5'");
}

TEST(CsvTable, BodyReadsQuantaVelocitiesAndBondMaterials) {
  const auto d = temp_dir("csv");
  write(d / "q.csv", "x,y,z,mass,vx,vy,vz\n0,0,0,1,0,0,0\n0.1,0,0,2,1,0,0\n0.1,0.1,0,3,0,1,0\n");
  write(d / "b.csv", "i,j,material\n0,1,soft\n1,2,hard\n");
  write(d / "scene.json", R"({"timestep": 0.001, "steps": 1,
    "materials": {"soft": {"stiffness": 10}, "hard": {"stiffness": 1000}},
    "bodies": [{"name": "t", "type": "csv", "quanta": "q.csv", "bonds": "b.csv", "velocity": [0, 0, 5]}]})");
  const Scene s = load_scene(d / "scene.json");
  ASSERT_EQ(s.world.num_quanta(), 3u);
  ASSERT_EQ(s.world.num_bonds(), 2u);
  std::map<Index, Index> at;  // user id → world index
  for (Index i = 0; i < 3; ++i) at[s.world.model.quanta_id[i]] = i;
  EXPECT_EQ(s.world.model.mass[at[2]], 3);
  // The table's velocities plus the body's velocity field.
  EXPECT_EQ(s.world.state.v[at[1]], Vec3(1, 0, 5));
  std::set<double> strengths(s.world.state.bonds.strength.begin(), s.world.state.bonds.strength.end());
  EXPECT_EQ(strengths, (std::set<double>{10, 1000}));
  write(d / "bad.json", R"({"timestep": 0.001, "steps": 1, "materials": {"soft": {"stiffness": 10}},
    "bodies": [{"name": "t", "type": "csv", "quanta": "q.csv", "bonds": "b.csv"}]})");
  EXPECT_PRED2(contains, error_of([&] { load_scene(d / "bad.json"); }), "unknown material 'hard'");
  write(d / "bad2.json", R"({"timestep": 0.001, "steps": 1,
    "bodies": [{"name": "t", "type": "csv", "quanta": "q.csv", "mass": 1}]})");
  EXPECT_PRED2(contains, error_of([&] { load_scene(d / "bad2.json"); }), "the quanta table has a mass column; drop 'mass'");
  std::filesystem::remove_all(d);
}

// ---- LAMMPS data files ------------------------------------------------------------------------

TEST(LammpsData, ReadsStylesImageFlagsAndSkipsWhatItDoesNotUse) {
  const std::string text =
      "title line\n\n  4 atoms\n 1 bonds\n 2 angles\n 2 atom types\n 1 bond types\n 1 angle types\n"
      "0 10 xlo xhi\n0 20 ylo yhi\n-1 1 zlo zhi\n\n"
      "Masses\n\n1 2.5\n2 4 # heavy\n\n"
      "Pair Coeffs # lj/cut\n\n1 1 1\n2 1 1\n\n"
      "Atoms # full\n\n"
      "7 1 2 -0.5 1 2 0.5 1 0 0\n3 1 1 0.5 4 5 0\n9 2 1 0 0 0 0 0 -1 0\n2 2 2 0 1 1 1\n\n"
      "Velocities\n\n3 1 0 0\n7 0 2 0\n9 0 0 3\n2 0 0 0\n\n"
      "Bonds\n\n1 1 3 7\n\nAngles\n\n1 1 3 7 9\n2 1 7 9 2\n";
  const LammpsData d = parse_lammps_data(text, "x.data");
  EXPECT_EQ(d.atom_id, (std::vector<long long>{2, 3, 7, 9}));  // sorted by ID
  EXPECT_EQ(d.atom_type, (std::vector<int>{2, 1, 2, 1}));
  EXPECT_EQ(d.x[2], Vec3(11, 2, 0.5));  // image flag +1 in x: + 10
  EXPECT_EQ(d.x[3], Vec3(0, -20, 0));   // −1 in y: − 20
  EXPECT_EQ(d.v[2], Vec3(0, 2, 0));
  EXPECT_EQ(d.type_mass, (std::vector<double>{2.5, 4}));
  EXPECT_EQ(d.bond_ends, (std::vector<std::pair<Index, Index>>{{1, 2}}));
  EXPECT_EQ(d.ignored, (std::vector<std::string>{"Pair Coeffs", "Angles"}));
  // The same atoms as atom_style bond need the style said.
  const AtomStyle atomic = AtomStyle::atomic;
  EXPECT_EQ(parse_lammps_data("t\n1 atoms\n1 atom types\nMasses\n\n1 1\n\nAtoms\n\n5 1 1 2 3\n", "a.data", &atomic).x[0],
            Vec3(1, 2, 3));
}

TEST(LammpsData, BadFilesNameFileAndLine) {
  auto err = [](const std::string& t) { return error_of([&] { parse_lammps_data(t, "x.data"); }); };
  const std::string head = "t\n2 atoms\n1 atom types\n0 1 xlo xhi\n";
  EXPECT_PRED2(contains, err(head + "Atoms\n\n1 1 1 0 0 0\n2 1 1 1 0 0\n"), "x.data: no Masses section");
  EXPECT_PRED2(contains, err(head + "Masses\n\n1 1\n\nAtoms\n\n1 1 3 0 0 0\n"), "x.data:11: atom type 3 is not in [1, 1]");
  EXPECT_PRED2(contains, err(head + "Masses\n\n1 1\n\nAtoms\n\n1 1 1 0 0\n"), "x.data:11: an Atoms line of this style is");
  EXPECT_PRED2(contains, err(head + "Masses\n\n1 1\n\nAtoms\n\n1 1 1 0 0 0\n1 1 1 1 0 0\n"), "x.data:12: atom ID 1 appears twice");
  EXPECT_PRED2(contains, err(head + "Masses\n\n1 1\n\nAtoms\n\n1 1 1 0 0 0\n"), "x.data:11: the file ends inside section Atoms");
  EXPECT_PRED2(contains, err("t\n2 atomz\n"), "x.data:2: unknown header line '2 atomz'");
  EXPECT_PRED2(contains, err("t\n1 atoms\n1 atom types\n1 bonds\n1 bond types\nMasses\n\n1 1\n\nAtoms\n\n1 1 1 0 0 0\n\nBonds\n\n1 1 1 5\n"),
                       "x.data:16: atom ID 5 is not in the Atoms section");
  EXPECT_PRED2(contains, err("t\n1 atoms\n1 atom types\nMasses\n\n1 1\n\nAtoms # sphere\n\n1 1 1 0 0 0\n"),
                       "x.data:8: atom style 'sphere' is not read");
}

namespace {

/// Compares two worlds quanta by quanta through the user ids and bond by bond through their
/// ends' user ids: positions, velocities and masses bit for bit; bond laws, strengths and damping
/// bit for bit; rest lengths bit for bit when `exact_rest`, else to 1e-15 relative.
void expect_same_structure(const World& a, const World& b, bool exact_rest) {
  ASSERT_EQ(a.num_quanta(), b.num_quanta());
  std::map<Index, Index> in_b;
  for (Index i = 0; i < b.num_quanta(); ++i) in_b[b.model.quanta_id[i]] = i;
  for (Index i = 0; i < a.num_quanta(); ++i) {
    const Index j = in_b.at(a.model.quanta_id[i]);
    for (int d = 0; d < 3; ++d) {
      EXPECT_EQ(std::bit_cast<std::uint64_t>(a.state.x[i][d]), std::bit_cast<std::uint64_t>(b.state.x[j][d]))
          << "x of quanta " << a.model.quanta_id[i];
      EXPECT_EQ(std::bit_cast<std::uint64_t>(a.state.v[i][d]), std::bit_cast<std::uint64_t>(b.state.v[j][d])) << "v of quanta " << a.model.quanta_id[i];
    }
    EXPECT_EQ(std::bit_cast<std::uint64_t>(a.model.mass[i]), std::bit_cast<std::uint64_t>(b.model.mass[j]));
  }
  auto key = [](const World& w, std::size_t k) {
    const Index p = w.model.quanta_id[w.state.bonds.i[k]], q = w.model.quanta_id[w.state.bonds.j[k]];
    return std::pair{std::min(p, q), std::max(p, q)};
  };
  std::map<std::pair<Index, Index>, std::size_t> bonds_b;
  for (std::size_t k = 0; k < b.num_bonds(); ++k) bonds_b[key(b, k)] = k;
  ASSERT_EQ(a.num_bonds(), b.num_bonds());
  for (std::size_t k = 0; k < a.num_bonds(); ++k) {
    const auto it = bonds_b.find(key(a, k));
    ASSERT_NE(it, bonds_b.end());
    const std::size_t m = it->second;
    EXPECT_EQ(a.state.bonds.law[k], b.state.bonds.law[m]);
    EXPECT_EQ(a.state.bonds.strength[k], b.state.bonds.strength[m]);
    EXPECT_EQ(a.state.bonds.damping[k], b.state.bonds.damping[m]);
    if (exact_rest)
      EXPECT_EQ(a.state.bonds.rest[k], b.state.bonds.rest[m]);
    else  // the body-frame distance against the placed one: a few roundings of coordinates ~1
      EXPECT_NEAR(a.state.bonds.rest[k], b.state.bonds.rest[m], 1e-15 * (1 + a.state.bonds.rest[k]));
  }
}

/// Writes the world of `scene` as a data file and reads it back as a `lammps` body whose bond
/// types take the materials that hold each type's stiffness.
Scene round_trip(const Scene& s, const std::string& materials, const std::map<double, std::string>& by_stiffness,
                 const std::filesystem::path& dir) {
  std::ofstream(dir / "w.data") << [&] {
    std::ostringstream o;
    write_lammps_data(o, s.world, s.name);
    return o.str();
  }();
  const auto [types, count] = lammps_bond_types(s.world);
  std::vector<std::string> names(static_cast<std::size_t>(count));
  std::size_t alive = 0;
  for (std::size_t k = 0; k < s.world.num_bonds(); ++k)
    if (s.world.state.bonds.alive[k]) names[static_cast<std::size_t>(types[alive++] - 1)] = by_stiffness.at(s.world.state.bonds.strength[k]);
  nlohmann::json j = {{"timestep", 0.001}, {"steps", 1}, {"materials", nlohmann::json::parse(materials)},
                      {"bodies", {{{"name", "read"}, {"type", "lammps"}, {"file", (dir / "w.data").string()},
                                   {"bond_materials", names}}}}};
  return parse_scene(j.dump());
}

}  // namespace

// scene → data file → scene: the same quanta and bonds bit for bit.
TEST(LammpsData, RoundTripIsBitExact) {
  const auto dir = temp_dir("lammps");
  const std::string materials = R"({"steel": {"stiffness": 20000, "damping": 0.5}, "rope": {"stiffness": 300}})";
  const std::map<double, std::string> by_stiffness{{20000, "steel"}, {300, "rope"}};
  // Unplaced bodies (origin 0, no rotation): the rest lengths are the distances of the very
  // positions written, so they too come back bit for bit.
  const Scene a = parse_scene(R"({"timestep": 0.001, "steps": 1, "materials": )" + materials + R"(,
    "bodies": [{"name": "block", "type": "lattice", "cell": "cubic", "size": [4, 3, 3], "spacing": 0.0137,
                "material": "steel", "quanta_mass": 0.0123, "velocity": [0.1, -0.2, 0.3]},
               {"name": "rope", "type": "chain", "start": [0.1, 0.3, 0.7], "end": [0.4, 0.9, 1.1], "count": 7,
                "material": "rope", "total_mass": 0.31}]})");
  expect_same_structure(a.world, round_trip(a, materials, by_stiffness, dir).world, true);
  // A rotated, translated, spinning body: positions, velocities and masses still bit for bit.
  const Scene b = parse_scene(R"({"timestep": 0.001, "steps": 1, "materials": )" + materials + R"(,
    "bodies": [{"name": "block", "type": "lattice", "cell": "fcc", "size": [2, 2, 1], "spacing": 0.0211,
                "material": "steel", "quanta_mass": 0.0123, "origin": [1.25, -3.5, 0.3333],
                "rotation": {"axis": [1, 2, 3], "angle": 0.7}, "angular_velocity": [0, 0, 2]}]})");
  expect_same_structure(b.world, round_trip(b, materials, by_stiffness, dir).world, false);
  std::filesystem::remove_all(dir);
}

// Every prefix of each example file, and each with one byte replaced by a stride of characters
// that matter to the readers, is read or refused with a std::runtime_error naming the file: no
// other exception, no crash (a deterministic complement of the mesh fuzz target, which also
// covers the CSV and LAMMPS readers here).
TEST(FileReaders, TruncatedOrCorruptedFilesAreReadOrRefused) {
  struct Case {
    std::filesystem::path file;
    void (*read)(const std::string& text, const std::string& name);
  };
  const Case cases[] = {
      {kSource / "scenes/meshes/bar.msh", [](const std::string& t, const std::string& n) { parse_tet_mesh(t, n); }},
      {kSource / "scenes/meshes/bar_v41.msh", [](const std::string& t, const std::string& n) { parse_tet_mesh(t, n); }},
      {kSource / "scenes/meshes/bar.vtu", [](const std::string& t, const std::string& n) { parse_tet_mesh(t, n); }},
      {kSource / "scenes/data/truss_quanta.csv", [](const std::string& t, const std::string& n) { parse_quanta_csv(t, n); }},
      {kSource / "scenes/data/truss_bonds.csv", [](const std::string& t, const std::string& n) { parse_bonds_csv(t, n, 13); }},
      {kSource / "scenes/data/block_and_rope.data", [](const std::string& t, const std::string& n) { parse_lammps_data(t, n); }},
  };
  const std::string replacements = "0-9 \n#,.$<>\"/e";
  for (const Case& c : cases) {
    const std::string text = read_file(c.file);
    const std::string name = c.file.filename().string();
    auto check = [&](const std::string& t) {
      try {
        c.read(t, name);
      } catch (const std::runtime_error& e) {
        ASSERT_TRUE(std::string(e.what()).starts_with(name)) << e.what();
      }
    };
    for (std::size_t n = 0; n <= text.size(); n += 11) check(text.substr(0, n));
    for (std::size_t p = 0; p < text.size(); p += 29)
      for (char r : replacements) {
        std::string t = text;
        t[p] = r;
        check(t);
      }
  }
}
