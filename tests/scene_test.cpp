// Scene files, builders and selections.
#include "qbond/io/scene.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string_view>

#include "qbond/analysis/analysis.hpp"
#include "qbond/builders/builders.hpp"
#include "qbond/builders/packing.hpp"
#include "qbond/io/files.hpp"
#include "qbond/io/json_text.hpp"
#include "qbond/io/scene_docs.hpp"
#include "qbond/laws/registry.hpp"
#include "qbond/model/ordering.hpp"
#include "qbond/model/selection.hpp"

namespace qbond {
namespace {

const std::filesystem::path kBad = std::filesystem::path(__FILE__).parent_path() / "bad_scenes";

// Reference bond count: pairs closer than `cut`, by brute force.
std::size_t pairs_closer(const World& w, double cut) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < w.num_quanta(); ++i)
    for (std::size_t j = i + 1; j < w.num_quanta(); ++j) n += (w.state.x[i] - w.state.x[j]).norm() < cut;
  return n;
}

TEST(Builders, SquareLatticeBondsNearestAndDiagonals) {
  for (bool diagonals : {false, true}) {
    World w;
    const int nx = 5, ny = 3;
    add_square_lattice(w, {{nx, ny}, 0.1, 1.0, diagonals, false, {.stiffness = 1}});
    EXPECT_EQ(w.num_quanta(), 15u);
    const std::size_t expected = nx * (ny - 1) + ny * (nx - 1) + (diagonals ? 2 * (nx - 1) * (ny - 1) : 0);
    EXPECT_EQ(w.num_bonds(), expected);
    EXPECT_EQ(w.num_bonds(), pairs_closer(w, diagonals ? 0.15 : 0.11));
    EXPECT_EQ(w.state.x[1], Vec3(0.1, 0, 0));  // ids run x fastest
  }
  World w;
  add_square_lattice(w, {{4, 4}, 0.1, 1.0, false, true, {.stiffness = 1}});
  EXPECT_EQ(w.num_bonds(), 24u + 16u);  // nearest + second neighbours along rows and columns
}

TEST(Builders, FccHasTwelveNeighboursInside) {
  World w;
  const double a = 0.1;
  add_fcc_lattice(w, {{3, 3, 3}, a, 1.0, false, {.stiffness = 1}});
  EXPECT_EQ(w.num_quanta(), 172u);  // half-spacing grid 7³ = 343 points, those with i + j + k even
  EXPECT_EQ(w.num_bonds(), pairs_closer(w, a / std::sqrt(2.0) * 1.01));
  std::vector<int> degree(w.num_quanta(), 0);
  for (std::size_t b = 0; b < w.num_bonds(); ++b) {
    ++degree[w.state.bonds.i[b]];
    ++degree[w.state.bonds.j[b]];
    EXPECT_NEAR(w.state.bonds.rest[b], a / std::sqrt(2.0), 1e-15);
  }
  // The interior face centre (1.5a, 1.5a, a) has all 12 neighbours.
  for (std::size_t i = 0; i < w.num_quanta(); ++i)
    if ((w.state.x[i] - Vec3(1.5 * a, 1.5 * a, a)).norm() < 1e-12) {
      EXPECT_EQ(degree[i], 12);
    }
  World w2;
  add_fcc_lattice(w2, {{2, 2, 2}, a, 1.0, true, {.stiffness = 1}});
  EXPECT_EQ(w2.num_bonds(), pairs_closer(w2, a * 1.01));
}

TEST(Builders, PlacementIsRigidAndGivesTheRigidVelocityField) {
  World w;
  CubicLattice l;
  l.size = {3, 2, 2};
  l.quanta_mass = 0.5;
  l.bond.stiffness = 1;
  const auto ids = add_cubic_lattice(w, l);
  const std::vector<double> rest = w.state.bonds.rest;
  Placement p;
  p.origin = Vec3(1, 2, 3);
  p.axis = Vec3(1, 1, 0).normalized();
  p.angle = 0.7;
  p.velocity = Vec3(0.1, -0.2, 0.3);
  p.angular_velocity = Vec3(0, 0, 2);
  place_body(w, ids, p);
  for (std::size_t b = 0; b < w.num_bonds(); ++b)
    EXPECT_NEAR((w.state.x[w.state.bonds.j[b]] - w.state.x[w.state.bonds.i[b]]).norm(), rest[b], 1e-14);
  const double M = 0.5 * 12;
  EXPECT_LT((linear_momentum(w.model, w.state) - M * p.velocity).norm(), 1e-13);
  // Angular momentum about the centre of mass = I ω, with I summed explicitly.
  Vec3 cm = Vec3::Zero();
  for (Index i : ids) cm += w.state.x[i] / 12.0;
  Mat3 I = Mat3::Zero();
  Vec3 L = Vec3::Zero();
  for (Index i : ids) {
    const Vec3 r = w.state.x[i] - cm;
    I += 0.5 * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
    L += 0.5 * r.cross(w.state.v[i]);
  }
  EXPECT_LT((L - I * p.angular_velocity).norm(), 1e-13);
}

// A keyframed motion: a quarter turn about z in 1 s, a rise of 1 m in the next second, then held.
// Linear: the exact pose and velocity inside each interval. Both interpolations: the velocity is
// the position's derivative (central differences), the poses are met at the keyframes, smooth
// ones at rest there.
TEST(Motions, KeyframesInterpolateAndHold) {
  const double pi = std::acos(-1.0);
  for (Interpolation interpolation : {Interpolation::linear, Interpolation::smooth}) {
    World w;
    const Index q = w.add_quanta(Vec3(1, 0, 0), Vec3::Zero(), 1.0);
    Motion m;
    m.type = MotionType::keyframes;
    m.axis = Vec3::UnitZ();
    m.interpolation = interpolation;
    m.keyframes = {{1.0, Vec3::Zero(), pi / 2}, {2.0, Vec3(0, 0, 1), pi / 2}};
    w.prescribe({q}, m);
    const Motion& p = w.model.motions.at(0);
    Vec3 x, v;
    auto at = [&](double t) {
      p.at(0, t, x, v);
      return x;
    };
    for (double t : {0.25, 0.5, 0.9, 1.3, 1.5, 1.99}) {
      at(t);
      const Vec3 v_exact = v;
      constexpr double d = 1e-4;
      const Vec3 fd = (at(t + d) - at(t - d)) / (2 * d);
      // The central difference errs by d²/6 times the third derivative, below 120 m/s³ here
      // (smooth: θ' <= 3π/4, θ'' <= 3π, θ''' = 6π, on a unit radius; the rise's 12 m/s³).
      EXPECT_LT((fd - v_exact).norm(), d * d / 6 * 120) << "t = " << t;
    }
    EXPECT_LT((at(1.0) - Vec3(0, 1, 0)).norm(), 1e-15);
    for (double t : {2.0, 2.5, 100.0}) {
      EXPECT_LT((at(t) - Vec3(0, 1, 1)).norm(), 1e-15) << "held at t = " << t;
      EXPECT_EQ(v, Vec3::Zero());
    }
    at(0.0);
    EXPECT_EQ(x, Vec3(1, 0, 0));
    if (interpolation == Interpolation::smooth) {
      EXPECT_EQ(v, Vec3::Zero());  // at rest at every keyframe
      at(1.0);
      EXPECT_LT(v.norm(), 1e-15);
    } else {
      at(0.5);  // an eighth of a turn, at π/2 rad/s
      EXPECT_LT((x - Vec3(std::cos(pi / 4), std::sin(pi / 4), 0)).norm(), 1e-15);
      EXPECT_LT((v - pi / 2 * Vec3(-std::sin(pi / 4), std::cos(pi / 4), 0)).norm(), 1e-15);
      at(1.5);  // half way up, at 1 m/s
      EXPECT_LT((x - Vec3(0, 1, 0.5)).norm(), 1e-15);
      EXPECT_LT((v - Vec3(0, 0, 1)).norm(), 1e-15);
    }
  }
  // Times must increase from 0.
  World w;
  const Index q = w.add_quanta(Vec3(1, 0, 0), Vec3::Zero(), 1.0);
  Motion m;
  m.type = MotionType::keyframes;
  m.keyframes = {{1.0, Vec3::Zero(), 0}, {1.0, Vec3(0, 0, 1), 0}};
  EXPECT_THROW(w.prescribe({q}, m), std::invalid_argument);
}

TEST(Selections, CriteriaIntersectAndBodyIdsAreLocal) {
  World w;
  const Index a = w.add_body("a"), b = w.add_body("b");
  for (int k = 0; k < 4; ++k) w.add_quanta(Vec3(k, 0, 0), Vec3::Zero(), 1, a);
  for (int k = 0; k < 4; ++k) w.add_quanta(Vec3(k, 1, 0), Vec3::Zero(), 1, b);
  Selection s;
  s.body = b;
  s.ids = std::vector<Index>{0, 3};
  EXPECT_EQ(select(w, s), (std::vector<Index>{4, 7}));
  s = {};
  s.box = {Vec3(0.5, -1, -1), Vec3(2.5, 2, 1)};
  EXPECT_EQ(select(w, s), (std::vector<Index>{1, 2, 5, 6}));
  s.half_space = {Vec3(0, 0.5, 0), Vec3(0, 1, 0)};
  EXPECT_EQ(select(w, s), (std::vector<Index>{5, 6}));
  s = {};
  s.sphere = {Vec3(0, 0, 0), 1.0};
  EXPECT_EQ(select(w, s), (std::vector<Index>{0, 1, 4}));
  s = {};
  s.ids = std::vector<Index>{8};
  EXPECT_THROW(select(w, s), std::out_of_range);
}

TEST(Scenes, EveryBadSceneFailsWithItsPathAndRule) {
  std::map<std::string, std::string> expected;
  std::ifstream in(kBad / "expected.txt");
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#') expected[line.substr(0, line.find('\t'))] = line.substr(line.find('\t') + 1);
  ASSERT_GE(expected.size(), 25u);
  std::size_t files = 0;
  for (const auto& e : std::filesystem::directory_iterator(kBad)) {
    if (e.path().extension() != ".json") continue;
    ++files;
    const std::string name = e.path().filename().string();
    ASSERT_TRUE(expected.count(name)) << name << " has no expectation";
    try {
      load_scene(e.path());
      ADD_FAILURE() << name << " loaded";
    } catch (const SceneError& err) {
      EXPECT_NE(std::string(err.what()).find(expected[name]), std::string::npos)
          << name << ": " << err.what() << "\nexpected: " << expected[name];
      EXPECT_EQ(std::string(err.what()).rfind(e.path().string(), 0), 0u) << "the message starts with the file";
    }
  }
  EXPECT_EQ(files, expected.size());
}

// A file of the source tree, whole.
std::string source_text(const std::string& relative) {
  std::ifstream f(std::string(QBOND_SOURCE_DIR) + "/" + relative);
  std::stringstream text;
  text << f.rdbuf();
  return text.str();
}

// A document's section from its heading to the next heading of the same level (or the end).
std::string doc_section(const std::string& doc, const std::string& heading) {
  const std::size_t start = doc.find("\n" + heading + "\n");
  if (start == std::string::npos) return {};
  const std::string level = "\n" + heading.substr(0, heading.find(' ') + 1);
  return doc.substr(start, doc.find(level, start + 1) - start);
}

// The message parse_scene gives for `text`, or "" when it parses.
std::string scene_error(const std::string& text) {
  try {
    parse_scene(text);
  } catch (const SceneError& e) {
    return e.what();
  }
  return {};
}

std::string joined(const std::vector<std::string_view>& keys) {
  std::string s;
  for (std::string_view k : keys) s += (s.empty() ? "" : ", ") + std::string(k);
  return s;
}

// The docs' row for a type: "| `type` | `key`, `key`, … |", its keys but those every type takes.
std::string key_row(const SceneType& t, const std::vector<SceneType>& all) {
  std::vector<std::string_view> own;
  for (std::string_view k : t.keys)
    if (!std::all_of(all.begin(), all.end(), [&](const SceneType& o) {
          return std::find(o.keys.begin(), o.keys.end(), k) != o.keys.end();
        }))
      own.push_back(k);
  std::string row = "| `" + std::string(t.type) + "` |";
  for (std::size_t i = 0; i < own.size(); ++i) row += (i ? ", `" : " `") + std::string(own[i]) + "`";
  return row + " |";
}

// Heuristic and body types are each one table, the scene reader's: the reader accepts every row's
// type with exactly the row's keys and lists the types it knows, and docs/scene-format.md's key
// tables have one row per type with exactly its keys.
TEST(Scenes, HeuristicAndBodyTypesAreOneTableTheReaderAndDocsFollow) {
  const std::string format = source_text("docs/scene-format.md");
  const std::string heuristics_doc = source_text("docs/heuristics.md");
  const std::string heuristics_section = doc_section(format, "## `heuristics`");
  const std::string bodies_section = doc_section(format, "## `bodies`");
  ASSERT_FALSE(heuristics_section.empty());
  ASSERT_FALSE(bodies_section.empty());
  ASSERT_GE(heuristic_types().size(), 9u);
  ASSERT_GE(body_types().size(), 7u);

  const std::string one_quanta = R"({"timestep": 0.001, "steps": 1, "bodies": [{"name": "a", "type": "quanta", "positions": [[0, 0, 0]], "mass": 1}], )";
  std::vector<std::string_view> heuristic_names;
  for (const SceneType& t : heuristic_types()) {
    const std::string type(t.type);
    heuristic_names.push_back(t.type);
    const std::string row = key_row(t, heuristic_types());
    EXPECT_NE(heuristics_section.find(row), std::string::npos)
        << "docs/scene-format.md's `heuristics` key table lacks the row " << row;
    EXPECT_NE(heuristics_doc.find("`" + type + "`"), std::string::npos) << "docs/heuristics.md does not name " << type;
    const std::string err =
        scene_error(one_quanta + R"("heuristics": [{"type": ")" + type + R"(", "no_such_key": 1}]})");
    EXPECT_NE(err.find("heuristics[0].no_such_key: unknown key (accepted: " + joined(t.keys) + ")"), std::string::npos)
        << type << ": " << err;
  }
  const std::string unknown = scene_error(one_quanta + R"("heuristics": [{"type": "no_such_type"}]})");
  EXPECT_NE(unknown.find("(accepted: " + joined(heuristic_names) + ")"), std::string::npos) << unknown;

  std::vector<std::string_view> body_names;
  for (const SceneType& t : body_types()) {
    const std::string type(t.type);
    body_names.push_back(t.type);
    const std::string row = key_row(t, body_types());
    EXPECT_NE(bodies_section.find(row), std::string::npos)
        << "docs/scene-format.md's `bodies` key table lacks the row " << row;
    const std::string err =
        scene_error(R"({"timestep": 0.001, "steps": 1, "bodies": [{"name": "b", "type": ")" + type + R"(", "no_such_key": 1}]})");
    EXPECT_NE(err.find("bodies[0].no_such_key: unknown key for a " + type + " body (accepted: " + joined(t.keys) + ")"),
              std::string::npos)
        << type << ": " << err;
  }
  const std::string unknown_body = scene_error(R"({"timestep": 0.001, "steps": 1, "bodies": [{"name": "b", "type": "no_such_type"}]})");
  EXPECT_NE(unknown_body.find("(accepted: " + joined(body_names) + ")"), std::string::npos) << unknown_body;
}

// The docs' key tables are written from the declarations (`qbond key-tables`), as the schema is:
// the committed docs hold each table between its markers exactly as the registries give it.
TEST(Scenes, DocsKeyTablesAreTheDeclarations) {
  const std::map<std::string, std::vector<std::string>> tables = {
      {"docs/scene-format.md", {"laws", "heuristics", "bodies", "integrator"}},
      {"docs/heuristics.md", {"heuristic_types"}}};
  for (const auto& [file, names] : tables) {
    const std::string text = source_text(file);
    for (const std::string& name : names) {
      const std::size_t open = text.find("<!-- keys:" + name + " -->\n");
      ASSERT_NE(open, std::string::npos) << file << " has no key table " << name;
      EXPECT_NE(text.find(scene_doc_table(name) + "<!-- /keys:" + name + " -->", open), std::string::npos)
          << file << "'s key table " << name << " differs from the declarations; regenerate: "
          << "build/qbond key-tables docs/scene-format.md docs/heuristics.md";
    }
    EXPECT_EQ(with_scene_doc_tables(text, file), text)
        << file << ": regenerate: build/qbond key-tables docs/scene-format.md docs/heuristics.md";
  }
  // A stale table is rewritten whole, the text around it kept; a wrong marker is refused.
  const std::string table = scene_doc_table("heuristics");
  EXPECT_EQ(with_scene_doc_tables("a\n<!-- keys:heuristics -->\n| old |\n<!-- /keys:heuristics -->\nb\n", "x.md"),
            "a\n<!-- keys:heuristics -->\n" + table + "<!-- /keys:heuristics -->\nb\n");
  for (const SceneType& t : heuristic_types())
    EXPECT_NE(table.find("| `" + std::string(t.type) + "` |"), std::string::npos) << t.type;
  for (const LawInfo& l : all_laws())
    EXPECT_NE(scene_doc_table("laws").find("| `" + std::string(l.name) + "` | `" + std::string(l.strength.key) + "` |"),
              std::string::npos)
        << l.name;
  EXPECT_THROW(scene_doc_table("no_such_table"), std::invalid_argument);
  try {
    with_scene_doc_tables("a\n\n<!-- keys:bodies -->\n| old |\n", "x.md");
    ADD_FAILURE() << "an unclosed table was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "x.md:3: key table 'bodies' has no <!-- /keys:bodies -->");
  }
  try {
    with_scene_doc_tables("<!-- keys:nope -->\n<!-- /keys:nope -->\n", "x.md");
    ADD_FAILURE() << "an unknown table was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "x.md:1: unknown key table 'nope' (known: laws, heuristics, heuristic_types, bodies, integrator)");
  }
  // The integrator table: every integrator in the `type` row, every option a row with its values
  // and the shipped default, and who reads it when not every integrator does.
  const std::string integrator = scene_doc_table("integrator");
  for (const IntegratorInfo& i : integrator_table())
    EXPECT_NE(integrator.find("`" + std::string(i.key) + "`"), std::string::npos) << i.key;
  for (const IntegratorOptionInfo& o : integrator_options())
    EXPECT_NE(integrator.find("| `" + std::string(o.key) + "` | "), std::string::npos) << o.key;
  EXPECT_NE(integrator.find("| `type` | `explicit_euler`, "), std::string::npos);
  EXPECT_NE(integrator.find(" | `coupled_implicit` |\n"), std::string::npos);
  EXPECT_NE(integrator.find("| `tolerance` | number > 0: "), std::string::npos);
  EXPECT_NE(integrator.find(" | 1e-6 |\n"), std::string::npos);
  EXPECT_NE(integrator.find("| `chebyshev_rho` | number ≥ 0, below 1: "), std::string::npos);
  EXPECT_NE(integrator.find(". Read by `hybrid_implicit` | `sweep` |\n"), std::string::npos);
}

TEST(Scenes, ResolvedSceneRebuildsTheSameWorld) {
  const std::string text = R"({
    "timestep": 0.001, "duration": 0.0105, "gravity": [0, 0, -9.81], "seed": 7,
    "materials": {"m": {"stiffness": 100, "damping": 0.5}, "i": {"law": "inverse", "stiffness": 2, "eps": 0.001}},
    "bodies": [
      {"name": "block", "type": "lattice", "cell": "fcc", "size": [1, 2, 1], "spacing": 0.1, "total_mass": 1,
       "material": "m", "rotation": {"axis": [0, 0, 1], "angle": 0.3}, "angular_velocity": [0, 0, 1]},
      {"name": "rope", "type": "chain", "start": [0, 0, 1], "end": [0, 0, 2], "count": 4, "quanta_mass": 0.1,
       "material": "i", "velocity": [1, 0, 0]},
      {"name": "cloth", "type": "sheet", "size": [3, 3], "spacing": 0.05, "bending": true, "quanta_mass": 0.01,
       "material": "m", "origin": [2, 0, 0]}
    ],
    "bonds": [{"from": {"body": "rope", "ids": [0]}, "to": {"body": "block"}, "within": 1.0, "material": "m"}],
    "anchors": [{"select": {"body": "rope", "ids": [3]}, "motion": {"translate": {"velocity": [0, 1, 0]}}}],
    "loads": [{"select": {"body": "cloth"}, "force": [0, 0, 1]}],
    "output": {"probes": [{"name": "top", "select": {"body": "rope", "ids": [3]}}]}
  })";
  const Scene a = parse_scene(text, "a.json");
  EXPECT_EQ(a.steps, 11u);  // ceil(0.0105 / 0.001)
  EXPECT_EQ(a.name, "a");
  EXPECT_FALSE(a.resolved.contains("duration"));
  const Scene b = parse_scene(a.resolved.dump(), "b.json");
  EXPECT_EQ(b.name, "a");
  ASSERT_EQ(a.world.num_quanta(), b.world.num_quanta());
  ASSERT_EQ(a.world.num_bonds(), b.world.num_bonds());
  EXPECT_EQ(a.world.state.x, b.world.state.x);
  EXPECT_EQ(a.world.state.v, b.world.state.v);
  EXPECT_EQ(a.world.state.bonds.rest, b.world.state.bonds.rest);
  EXPECT_EQ(a.world.model.mass, b.world.model.mass);
  EXPECT_EQ(a.world.state.bonds.i, b.world.state.bonds.i);
  EXPECT_EQ(a.world.state.bonds.strength, b.world.state.bonds.strength);
  EXPECT_EQ(a.world.model.motions.size(), 1u);
  EXPECT_EQ(a.world.state.rng.state, 7u);
  EXPECT_EQ(a.output.probes.at(0).quanta, std::vector<Index>{a.world.model.motions[0].quanta[0]});
  double total = 0;
  for (Index i = 0; i < a.world.num_quanta(); ++i)
    if (a.world.model.body[i] == 0) total += a.world.model.mass[i];
  EXPECT_NEAR(total, 1.0, 1e-12);  // total_mass spread over the FCC sites
}

// `//` and `/* */` comments and `description`/`notes` on any object are kept in the resolved
// scene but change nothing in the world.
TEST(Scenes, CommentsAndNotesChangeNothing) {
  const std::string plain = R"({
    "timestep": 0.001, "steps": 3, "gravity": [0, 0, -9.81],
    "materials": {"m": {"stiffness": 100, "damping": 0.5}},
    "integrator": {"type": "coupled_implicit"},
    "bodies": [{"name": "rope", "type": "chain", "start": [0, 0, 0], "end": [0, 0, -1], "count": 5,
                "quanta_mass": 0.1, "material": "m", "rotation": {"axis": [0, 1, 0], "angle": 0.2}}],
    "anchors": [{"select": {"ids": [0]}, "motion": {"rotate": {"axis": [0, 0, 1], "center": [0, 0, 0], "rate": 1}}}],
    "loads": [{"select": {"sphere": {"center": [0, 0, -1], "radius": 0.3}}, "force": [1, 0, 0]}],
    "heuristics": [{"type": "break", "max_strain": 0.5}],
    "output": {"probes": [{"name": "top", "select": {"ids": [0]}}]}
  })";
  const std::string annotated = R"(// a rope, twisted at its top
  {
    "timestep": 0.001, "steps": 3, "gravity": [0, 0, -9.81],  /* Earth's */
    "materials": {"notes": "the section's own", "m": {"stiffness": 100, "damping": 0.5, "description": "steel"}},
    "integrator": {"type": "coupled_implicit", "notes": ["the default", "written out"]},
    "bodies": [{"name": "rope", "type": "chain", "start": [0, 0, 0], "end": [0, 0, -1], "count": 5,
                "quanta_mass": 0.1, "material": "m", "notes": "1 m",
                "rotation": {"axis": [0, 1, 0], "angle": 0.2, "description": "tilted"}}],
    "anchors": [{"select": {"ids": [0], "notes": "the top"}, "notes": "turns",
                 "motion": {"rotate": {"axis": [0, 0, 1], "center": [0, 0, 0], "rate": 1, "description": "1 rad/s"}}}],
    "loads": [{"select": {"sphere": {"center": [0, 0, -1], "radius": 0.3, "notes": "the end"}}, "force": [1, 0, 0],
               "description": "a push"}],
    "heuristics": [{"type": "break", "max_strain": 0.5, "notes": "50 %"}],
    "output": {"probes": [{"name": "top", "select": {"ids": [0]}, "description": "where it turns"}], "notes": "x"}
  })";
  const Scene a = parse_scene(plain, "a.json"), b = parse_scene(annotated, "a.json");
  EXPECT_EQ(a.world.model, b.world.model);
  EXPECT_EQ(a.world.state.x, b.world.state.x);
  EXPECT_EQ(a.world.state.bonds.rest, b.world.state.bonds.rest);
  EXPECT_EQ(a.heuristics.size(), b.heuristics.size());
  EXPECT_EQ(b.resolved["bodies"][0]["notes"], "1 m");
  EXPECT_EQ(parse_scene(b.resolved.dump(), "b.json").world.model, b.world.model);  // resumes read them too
  // A note is text: anything else is refused with its path, and comments only in scene files.
  try {
    parse_scene(
        R"({"timestep": 1, "steps": 1, "bodies": [{"name": "a", "type": "quanta", "positions": [[0, 0, 0]],
                    "mass": 1, "notes": 3}]})");
    ADD_FAILURE() << "a numeric note was accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.path, "bodies[0].notes");
    EXPECT_EQ(e.rule, "expected a string or an array of strings, got a number");
  }
  EXPECT_THROW(parse_json_strict("{\"a\": 1 /* no */}"), JsonTextError);
  EXPECT_EQ(parse_json_strict("{\"a\": 1 /* yes */}", kMaxJsonDepth, true)["a"], 1);
}

// Loading renumbers the world for locality (ordering.hpp); everything the scene selected follows
// its quanta, and ids keep meaning creation order. The packing comes in sampling order, not by
// position, so the renumbering is not the identity here.
TEST(Scenes, RenumberingKeepsSelectionsRulesProbesAndIds) {
  const Scene s = parse_scene(R"({
    "timestep": 0.001, "steps": 1, "seed": 3,
    "materials": {"m": {"stiffness": 100}},
    "bodies": [{"name": "block", "type": "packing", "points": "poisson", "size": [0.1, 0.05, 0.05],
                "min_distance": 0.01, "bond_radius": 0.017, "material": "m", "total_mass": 0.2}],
    "anchors": [{"select": {"box": [[-1, -1, -1], [0.02, 1, 1]]}}],
    "heuristics": [{"type": "break", "max_strain": 0.2, "select": {"box": [[0.05, -1, -1], [1, 1, 1]]}}],
    "output": {"probes": [{"name": "far", "select": {"box": [[0.08, -1, -1], [1, 1, 1]]}},
                          {"name": "five", "select": {"ids": [5]}}]}
  })", "renumbered.json");
  const World& w = s.world;
  const Model& m = w.model;
  const std::size_t n = w.num_quanta();
  const std::vector<Index> at = quanta_by_id(m);
  std::size_t moved = 0;
  for (std::size_t i = 0; i < n; ++i) moved += m.quanta_id[i] != i;
  EXPECT_GT(moved, n / 2);
  // Quanta id k is the packing's k-th point.
  PointPacking packing;
  packing.size = Vec3(0.1, 0.05, 0.05);
  packing.min_distance = 0.01;
  packing.seed = 3;
  const auto points = sample_points(packing);  // none isolated at this bond radius: none dropped
  ASSERT_EQ(points.size(), n);
  for (std::size_t k = 0; k < n; ++k) EXPECT_EQ(w.state.x[at[k]], points[k]);
  // Bonds still join the quanta they joined, at their rest lengths.
  for (std::size_t b = 0; b < w.num_bonds(); ++b)
    EXPECT_DOUBLE_EQ((w.state.x[w.state.bonds.i[b]] - w.state.x[w.state.bonds.j[b]]).norm(), w.state.bonds.rest[b]);
  const auto& rule = std::get<BreakRule>(s.heuristics.at(0));
  std::vector<Index> far;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3& x = w.state.x[i];
    EXPECT_EQ(m.is_kinematic(static_cast<Index>(i)), x.x() <= 0.02) << i;
    EXPECT_EQ(rule.quanta.at(i), x.x() >= 0.05) << i;
    if (x.x() >= 0.08) far.push_back(static_cast<Index>(i));
  }
  EXPECT_EQ(s.output.probes.at(0).quanta, far);
  EXPECT_EQ(s.output.probes.at(1).quanta, std::vector<Index>{at[5]});
  Selection five;
  five.ids = std::vector<Index>{5};
  EXPECT_EQ(select(w, five), std::vector<Index>{at[5]});
}

// integrator.newton_polish (docs/scene-format.md) is read, resolved and read back; off by default.
TEST(Scenes, NewtonPolishIsReadAndResolved) {
  const std::string text = R"({
    "timestep": 0.001, "steps": 1, "integrator": {"type": "energy_momentum", "newton_polish": true},
    "materials": {"m": {"stiffness": 100}},
    "bodies": [{"name": "rope", "type": "chain", "start": [0, 0, 0], "end": [0, 0, 1], "count": 3,
                "quanta_mass": 0.1, "material": "m"}]
  })";
  const Scene a = parse_scene(text, "a.json");
  EXPECT_TRUE(a.integrator.newton_polish);
  EXPECT_EQ(a.resolved["integrator"]["newton_polish"], true);
  EXPECT_TRUE(parse_scene(a.resolved.dump(), "b.json").integrator.newton_polish);
  std::string off = text;
  off.replace(off.find(", \"newton_polish\": true"), std::string(", \"newton_polish\": true").size(), "");
  EXPECT_FALSE(parse_scene(off, "c.json").integrator.newton_polish);
}

TEST(Scenes, ExplicitStepHintIsTheHarmonicLimit) {
  // Two quanta (m) on one bond (k): ω² = 2k/m, and the Gershgorin bound 2 Σk/m is exact here.
  const Scene s = parse_scene(R"({"timestep": 0.01, "steps": 1, "materials": {"s": {"stiffness": 100}},
    "bodies": [{"name": "p", "type": "quanta", "positions": [[0,0,0],[1,0,0]], "mass": 1}],
    "bonds": [{"between": [0, 1], "material": "s"}]})");
  EXPECT_DOUBLE_EQ(explicit_step_hint(s.world), 2 / std::sqrt(200.0));
  EXPECT_NE(scene_summary(s).find("quanta     2"), std::string::npos);
}

}  // namespace
}  // namespace qbond
