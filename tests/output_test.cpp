// Checkpoints, probes, diagnostics rows and VTK frames.
#include <gtest/gtest.h>
#include <unistd.h>

#include <sys/stat.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "qbond/io/checkpoint.hpp"
#include "qbond/io/checksum.hpp"
#include "qbond/io/diagnostics.hpp"
#include "qbond/io/files.hpp"
#include "qbond/model/ordering.hpp"
#include "qbond/io/probes.hpp"
#include "qbond/io/vtk.hpp"
#include "qbond/io/vtp_reader.hpp"
#include "qbond/analysis/analysis.hpp"
#include "qbond/analysis/stress.hpp"
#include "integrators/affine_run_terms.hpp"  // soa_stride
#include "test_util.hpp"

namespace qbond {
namespace {
namespace fs = std::filesystem;

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("qbond_output_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

State distinctive_state() {
  State s;
  s.x = {Vec3(1, 2, 3), Vec3(-4, 5e-300, 6)};
  s.v = {Vec3(0.1, 0.2, 0.3), Vec3(7, 8, 9)};
  // Two bonds of the scene, one formed during the run, one broken, one rest length flowed.
  s.add_bond(0, 1, {Law::linear, DampingModel::axial, 100, 0.5, 0}, 1.5);
  s.add_bond(1, 0, {Law::morse, DampingModel::isotropic, 2.5, 0.25, 1}, 2.5);
  s.time = 0.0625;
  s.form_bond(0, 1, {Law::inverse, DampingModel::isotropic, 10, 0.5, 2}, 3.5, 2);
  s.time = 0.25;
  s.break_bond(1);
  s.bonds.rest[0] = 1.25;
  s.time = 0.125;
  s.step = 1234567890123ull;
  s.rng.state = 0xDEADBEEFCAFEF00Dull;
  s.energy = {1, 2, 3, 4, 5, 6, 7, true};
  s.carry = SolverGuess{{Vec3(1e-3, 2e-3, 3e-3), Vec3(-1, -2, -3)}};
  return s;
}

TEST(Checkpoint, RoundTripIsExact) {
  const State s = distinctive_state();
  const std::string bytes = serialize_state(s);
  EXPECT_EQ(serialize_state(deserialize_state(bytes)), bytes);
  const fs::path f = temp_dir("roundtrip") / "c.qbc";
  save_checkpoint(f, "{\"k\": 1}", s);
  const Checkpoint c = load_checkpoint(f);
  EXPECT_EQ(c.metadata, "{\"k\": 1}");
  EXPECT_EQ(serialize_state(c.state), bytes);
  EXPECT_EQ(std::distance(fs::directory_iterator(f.parent_path()), fs::directory_iterator{}), 1)
      << "no temporary file is left behind";
}

// One carry-over of each kind for distinctive_state's two quanta, with values whose bits a pass
// through decimal text or float would change.
std::vector<Carry> every_carry() {
  const double odd = std::nextafter(0.1, 1.0), tiny = 5e-310;  // tiny: subnormal
  const SolverGuess guess{{Vec3(1e-3, -0.0, odd), Vec3(-1, tiny, 3)}};
  const SolverGuessPair pair{{Vec3(odd, 2, 3), Vec3(4, -5, tiny)}, {Vec3(-0.0, 1, 2), Vec3(3, odd, 5)}, 1e-3, odd};
  const Bdf2History history{{Vec3(1, 2, odd), Vec3(tiny, 5, 6)}, {Vec3(-1, -0.0, 3), Vec3(odd, 1, 2)}, 0.125 - 1e-3,
                            1e-3, 1234567890122ull};
  VerletForces verlet;
  verlet.resize(2);
  for (std::size_t c = 0; c < 3; ++c)
    for (std::size_t q = 0; q < 2; ++q) {
      verlet.f[c * verlet.stride() + q] = odd * static_cast<double>(c + 3 * q + 1);
      verlet.x[c * verlet.stride() + q] = -tiny * static_cast<double>(c + 1) + static_cast<double>(q);
    }
  verlet.v = {Vec3(odd, -odd, 1), Vec3(2, tiny, -0.0)};
  verlet.topology_version = 42;
  return {std::monostate{}, guess, pair, history, verlet};
}

// Every kind of carry-over comes back from a checkpoint bit for bit, as the same kind; one for
// another number of quanta, or of a kind this build does not know, is refused.
TEST(Checkpoint, EveryCarryKindRoundTripsBitForBit) {
  for (const Carry& c : every_carry()) {
    State s = distinctive_state();
    s.carry = c;
    const std::string bytes = serialize_state(s);
    const State back = deserialize_state(bytes);
    EXPECT_EQ(back.carry.index(), c.index());
    EXPECT_TRUE(back.carry == c) << c.index();
    EXPECT_EQ(serialize_state(back), bytes) << c.index();
    if (std::holds_alternative<std::monostate>(c)) continue;
    s.x.push_back(Vec3::Zero());
    s.v.push_back(Vec3::Zero());
    EXPECT_THROW(deserialize_state(serialize_state(s)), CheckpointError) << c.index();
  }
  State s = distinctive_state();
  s.carry = std::monostate{};
  std::string bytes = serialize_state(s);
  // The kind tag is the last byte before the obstacle impulses' (empty) vector.
  ASSERT_EQ(bytes[bytes.size() - 9], 0);
  bytes[bytes.size() - 9] = 9;
  try {
    deserialize_state(bytes);
    ADD_FAILURE() << "an unknown carry-over kind was read";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown carry-over kind 9"), std::string::npos) << e.what();
  }
}

// Version 4 kept every carry-over in one array of triples; the reader converts each layout to its
// kind, bit for bit.
TEST(Checkpoint, Version4CarryOversAreConverted) {
  const std::size_t n = 2;
  const std::vector<Carry> carries = every_carry();
  const auto& guess = std::get<SolverGuess>(carries[1]);
  const auto& pair = std::get<SolverGuessPair>(carries[2]);
  const auto& history = std::get<Bdf2History>(carries[3]);
  const auto& verlet = std::get<VerletForces>(carries[4]);
  EXPECT_TRUE(carry_from_version4({}, n) == Carry{});
  EXPECT_TRUE(carry_from_version4(guess.dv, n) == Carry{guess});
  LineVector<Vec3> old(pair.dv.begin(), pair.dv.end());
  old.insert(old.end(), pair.dv_before.begin(), pair.dv_before.end());
  old.push_back(Vec3(pair.h, pair.h_before, -1));
  EXPECT_TRUE(carry_from_version4(old, n) == Carry{pair});
  old.assign(history.x.begin(), history.x.end());
  old.insert(old.end(), history.v.begin(), history.v.end());
  old.push_back(Vec3(history.t, history.h, static_cast<double>(history.step)));
  EXPECT_TRUE(carry_from_version4(old, n) == Carry{history});
  old.assign(2 * verlet.stride(), Vec3::Zero());
  std::copy(verlet.f.begin(), verlet.f.end(), old.data()->data());
  std::copy(verlet.x.begin(), verlet.x.end(), old.data()->data() + 3 * verlet.stride());
  old.insert(old.end(), verlet.v.begin(), verlet.v.end());
  old.push_back(Vec3(static_cast<double>(verlet.topology_version), 0, 0));
  EXPECT_TRUE(carry_from_version4(old, n) == Carry{verlet});
  EXPECT_TRUE(carry_from_version4(LineVector<Vec3>(3 * n + 1), n) == Carry{});  // Verlet's older layout
  EXPECT_THROW(carry_from_version4(LineVector<Vec3>(n + 1), n), CheckpointError);
}

// A run interrupted by a checkpoint file and resumed from it continues bit for bit, carry-over
// included, whatever its integrator carries from step to step; without the carry-over it would
// not (the resumed steps would start afresh).
TEST(Checkpoint, ResumedRunsContinueBitForBit) {
  World w = test::lattice(4, 3, 3, 5e3, 0.2, 0.5, true, Vec3(0, 0, -9.81));
  test::perturb(w, 1e-4, 0.05);
  const fs::path f = temp_dir("resume") / "c.qbc";
  for (const auto& [name, cfg] : test::carrying_integrators()) {
    const double h = 5e-4;
    Simulation a(w, cfg, h);
    for (int k = 0; k < 10; ++k) a.step();
    save_checkpoint(f, "{}", a.world().state);
    World resumed = w, dropped = w;
    resumed.state = load_checkpoint(f).state;
    EXPECT_TRUE(resumed.state.carry == a.world().state.carry) << name;
    dropped.state = resumed.state;
    dropped.state.carry = std::monostate{};
    Simulation b(std::move(resumed), cfg, h), c(std::move(dropped), cfg, h);
    for (int k = 0; k < 10; ++k) {
      a.step();
      b.step();
      c.step();
    }
    test::expect_same_bits(a.world().state, b.world().state);
    EXPECT_TRUE(a.world().state.carry == b.world().state.carry) << name;
    EXPECT_NE(a.world().state.x, c.world().state.x) << name << ": the carry-over changes nothing";
  }
}

TEST(Checkpoint, EveryTruncationAndEveryFlippedByteIsRefused) {
  const fs::path dir = temp_dir("corrupt");
  const fs::path f = dir / "c.qbc", bad = dir / "bad.qbc";
  save_checkpoint(f, "{}", distinctive_state());
  const std::string bytes = read_file(f);
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    write_file_atomic(bad, bytes.substr(0, n));
    EXPECT_THROW(load_checkpoint(bad), CheckpointError) << "prefix of " << n << " bytes";
  }
  for (std::size_t k = 8; k < bytes.size(); ++k) {
    std::string b = bytes;
    b[k] ^= 0x10;
    write_file_atomic(bad, b);
    EXPECT_THROW(load_checkpoint(bad), CheckpointError) << "byte " << k;
  }
  std::string b = bytes;
  b[0] = 'X';
  write_file_atomic(bad, b);
  try {
    load_checkpoint(bad);
    FAIL();
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("not a qbond checkpoint"), std::string::npos) << e.what();
  }
  b = bytes;
  b[8] = 9;  // version 9
  write_file_atomic(bad, b);
  try {
    load_checkpoint(bad);
    FAIL();
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("unsupported checkpoint version 9"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(bad.string()), std::string::npos) << e.what();
  }
}

// XXH64 gives the xxHash specification's values (the same as the reference library's
// XXH64(data, len, 0)): the empty input, a short one (tail bytes only) and one of 39 bytes (a
// 32-byte stripe and a tail of 8, 4 and 1-byte steps).
TEST(Checksum, Xxh64MatchesTheSpecification) {
  EXPECT_EQ(xxh64(""), 0xEF46DB3751D8E999ull);
  EXPECT_EQ(xxh64("abc"), 0x44BC2CF5AD770999ull);
  EXPECT_EQ(xxh64("Nobody inspects the spammish repetition"), 0xFBCEA83C8A378BF1ull);
}

// A version-4 carry-over whose counts (BDF2's step, Verlet's topology version) are not whole
// numbers in [0, 2^64) is refused, not cast (undefined behaviour); found by the checkpoint fuzzer
// (fuzz/regressions/checkpoint/version4_carry_count_out_of_range).
TEST(Checkpoint, Version4CountsOutOfRangeAreRefused) {
  const std::size_t n = 2;
  for (double bad : {2.2e78, -2.0, 0.5, std::nan("")}) {  // (-1 marks a CG pair, not BDF2)
    LineVector<Vec3> bdf2(2 * n + 1, Vec3(1, 2, 3));
    bdf2.back() = Vec3(0.5, 1e-3, bad);
    EXPECT_THROW(carry_from_version4(bdf2, n), CheckpointError) << bad;
    LineVector<Vec3> verlet(2 * soa_stride(n) + n + 1, Vec3(1, 2, 3));
    verlet.back() = Vec3(bad, 0, 0);
    EXPECT_THROW(carry_from_version4(verlet, n), CheckpointError) << bad;
  }
}

// A version-5 file (same layout, FNV-1a checksum) is still read, to the same state.
TEST(Checkpoint, Version5FilesAreStillRead) {
  // A file the build before format 6 wrote (FNV-1a checksum, formed bonds saved apart).
  const std::string bytes = read_file(fs::path(QBOND_SOURCE_DIR) / "tests/checkpoints_v5/splash.qbc");
  const fs::path dir = temp_dir("v5");
  write_file_atomic(dir / "v5.qbc", bytes);
  const Checkpoint c = load_checkpoint(dir / "v5.qbc");
  EXPECT_EQ(c.version, 5u);
  EXPECT_TRUE(c.formed_before_v6.has_value());
  std::string relabelled = bytes;
  relabelled[8] = 6;  // the same bytes claiming version 6 fail its checksum
  write_file_atomic(dir / "v6.qbc", relabelled);
  EXPECT_THROW(load_checkpoint(dir / "v6.qbc"), CheckpointError);
}

// What is not a regular file is refused before it is read: a FIFO with no writer (which would
// block), /dev/zero (which never ends), a directory; an 8 GiB sparse file is refused from its
// header alone. Each within a second, naming the file.
TEST(Checkpoint, SpecialAndHugeFilesAreRefusedUnread) {
  const fs::path dir = temp_dir("special");
  const fs::path fifo = dir / "fifo.qbc", sparse = dir / "sparse.qbc";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  fs::create_directory(dir / "dir.qbc");
  { std::ofstream(sparse).close(); }
  fs::resize_file(sparse, std::uintmax_t{8} << 30);
  for (const auto& [path, says] : std::vector<std::pair<fs::path, std::string>>{
           {fifo, "a FIFO"}, {"/dev/zero", "a character device"}, {dir / "dir.qbc", "a directory"},
           {sparse, "no QBONDCKP header"}}) {
    const auto t0 = std::chrono::steady_clock::now();
    try {
      load_checkpoint(path);
      ADD_FAILURE() << path << " was read";
    } catch (const CheckpointError& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
    }
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0) << path;
    EXPECT_THROW(read_file(path), std::runtime_error) << path;
  }
  // A file larger than the caller allows is refused by its size.
  write_file_atomic(dir / "text", std::string(100, 'x'));
  EXPECT_THROW(read_file(dir / "text", 99), std::runtime_error);
  EXPECT_EQ(read_file(dir / "text", 100).size(), 100u);
}

// Temporaries of dead writers are removed; those of live ones (this process) and other files stay.
TEST(Files, StaleTemporariesOfDeadProcessesAreRemoved) {
  const fs::path d = temp_dir("stale");
  const std::string live = std::to_string(::getpid());
  // A process id above the kernel's pid_max (at most 2^22) never belongs to a live process.
  for (const char* name : {".checkpoint.qbc.tmp.4999999", ".frame_0000000010.vtp.tmp.4999998"})
    write_file_atomic(d / name, "partial");
  for (const std::string& name : {".run.json.tmp." + live, std::string("notes.tmp.4999999"), std::string("a.txt")})
    write_file_atomic(d / name, "kept");
  EXPECT_EQ(remove_stale_temporaries(d), 2u);
  EXPECT_FALSE(fs::exists(d / ".checkpoint.qbc.tmp.4999999"));
  EXPECT_TRUE(fs::exists(d / (".run.json.tmp." + live)));
  EXPECT_TRUE(fs::exists(d / "notes.tmp.4999999"));
  EXPECT_TRUE(fs::exists(d / "a.txt"));
}

// Both durabilities write the whole file under its name and leave no temporary beside it; the
// file system flush names a directory it cannot open.
TEST(Files, AtomicAndDurableWritesLeaveTheFileAloneAndFlushNamesItsDirectory) {
  const fs::path d = temp_dir("files");
  write_file_atomic(d / "a.txt", "atomic", Durability::atomic);
  write_file_atomic(d / "b.txt", "durable", Durability::durable);
  write_file_atomic(d / "a.txt", "atomic, again", Durability::atomic);
  EXPECT_EQ(read_file(d / "a.txt"), "atomic, again");
  EXPECT_EQ(read_file(d / "b.txt"), "durable");
  EXPECT_EQ(std::distance(fs::directory_iterator(d), fs::directory_iterator()), 2);
  EXPECT_NO_THROW(flush_file_system(d));
  try {
    flush_file_system(d / "missing");
    ADD_FAILURE() << "no error for a missing directory";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("missing"), std::string::npos) << e.what();
  }
}

// A mass m hanging at rest from an anchored quanta on one bond stretched by m g / k: the support
// holds it with m g upward, and the torque about a point d to the side is d × (m g).
TEST(Probes, ReactionOfAHangingMassIsItsWeight) {
  World w;
  const double m = 2.0, k = 500.0, g = 9.81;
  w.model.gravity = Vec3(0, 0, -g);
  w.add_quanta(Vec3(0, 0, 0), Vec3::Zero(), 1.0);
  w.add_quanta(Vec3(0, 0, -(1.0 + m * g / k)), Vec3::Zero(), m);
  w.add_bond(0, 1, {.stiffness = k, .damping = 3.0, .rest_length = 1.0});
  w.prescribe({0}, Motion{});
  const Probe support{"support", {0}, Vec3(0.5, 0, 0)};
  const ProbeValue v = measure_probe(w.model, w.state, support);
  ASSERT_TRUE(v.has_reaction);
  EXPECT_NEAR((v.force - Vec3(0, 0, m * g)).norm(), 0, 1e-12 * m * g);
  // Torque about c of the force at x = 0: (0 - c) × F.
  EXPECT_NEAR((v.torque - Vec3(-0.5, 0, 0).cross(Vec3(0, 0, m * g))).norm(), 0, 1e-12 * m * g);
  EXPECT_FALSE(measure_probe(w.model, w.state, {"mass", {1}, {}}).has_reaction);
  EXPECT_EQ(measure_probe(w.model, w.state, {"mass", {1}, {}}).mean, w.state.x[1]);
  // Moving apart at 1 m/s along the bond, the damper adds D·1 m/s to the pull.
  w.state.v[1] = Vec3(0, 0, -1);
  EXPECT_NEAR(measure_probe(w.model, w.state, support).force.z(), m * g + 3.0, 1e-12);
}

// A probe over a uniformly stretched lattice's interior reads its Cauchy–Born stress C : ε, and
// the diagnostics row carries it.
TEST(Probes, StressOfAUniformlyStrainedInteriorIsCauchyBorn) {
  const double k = 100, a = 0.01, e = 1e-6;
  World w = test::lattice(5, 5, 5, k, 1e-3, 0, false);
  std::vector<Index> inner;
  for (std::size_t i = 0; i < w.num_quanta(); ++i) {
    const Vec3 g = w.state.x[i] / a;
    if ((g.array() > 0.5).all() && (g.array() < 3.5).all()) inner.push_back(static_cast<Index>(i));
    w.state.x[i].x() *= 1 + e;
  }
  ASSERT_EQ(inner.size(), 27u);
  const Probe probe{"core", inner, {}};
  const ProbeValue v = measure_probe(w.model, w.state, probe);
  ASSERT_TRUE(v.has_stress);
  // Cubic lattice with face diagonals: σ_xx = C11 ε = 3k/a ε, σ_yy = σ_zz = C12 ε = k/a ε, up to
  // the geometric terms of relative size ε (T r grows as ε (1 + ε)).
  const double tol = 3 * e * 3 * k / a * e;
  EXPECT_NEAR(v.stress(0, 0), 3 * k / a * e, tol);
  EXPECT_NEAR(v.stress(1, 1), k / a * e, tol);
  EXPECT_NEAR(v.stress(0, 1), 0, tol);
  EXPECT_NEAR(v.von_mises_max, 2 * k / a * e, tol);  // σ_xx − σ_yy for this state
  const Diagnostics d(w.model, {probe});
  EXPECT_NE(d.header().find("core_z,core_sxx,core_syy,core_szz,core_syz,core_sxz,core_sxy,core_von_mises_max,work"),
            std::string::npos);
  const std::string row = d.row(w.model, w.state, {});
  char sxx[32];
  std::snprintf(sxx, sizeof sxx, "%.17g", v.stress(0, 0));
  EXPECT_NE(row.find(sxx), std::string::npos);
}

TEST(Diagnostics, HeaderAndRowMatchTheAnalysis) {
  World w = test::two_quanta(1.0, 100.0, 1.0, 0.1, 0.5);
  w.prescribe({0}, Motion{});
  const Diagnostics d(w.model, {{"a", {0}, {}}, {"b", {1}, {}}});
  EXPECT_EQ(d.header(),
            "step,time,kinetic,potential,dissipated,total,px,py,pz,lx,ly,lz,max_speed,bonds_alive,bonds_broken,"
            "a_x,a_y,a_z,a_fx,a_fy,a_fz,a_tx,a_ty,a_tz,b_x,b_y,b_z,work,numerical_damping,numerical,iterations,residual,"
            "timestep");
  const std::string row = d.row(w.model, w.state, {3, 1e-7}, 2.5e-4);
  std::vector<std::string> f;
  for (std::size_t p = 0, q; p <= row.size(); p = q + 1) {
    q = row.find(',', p);
    if (q == std::string::npos) q = row.size();
    f.push_back(row.substr(p, q - p));
  }
  ASSERT_EQ(f.size(), 33u);
  EXPECT_EQ(std::stod(f[32]), 2.5e-4);
  const Energies e = energies(w.model, w.state);
  EXPECT_EQ(std::stod(f[2]), e.kinetic);
  EXPECT_EQ(std::stod(f[3]), e.bonds + e.gravity);
  EXPECT_NEAR(std::stod(f[18]), -10.0, 1e-12);  // a_fx: the stretched bond pulls the anchor by k s = 10 N
  EXPECT_EQ(f[13], "1");
  EXPECT_EQ(f[30], "3");
}

TEST(Vtk, FrameDeclaresItsCountsAndSeriesListsFrames) {
  World w = test::lattice(2, 2, 1, 100, 1e-3, 0, false);
  w.break_bond(0);
  const fs::path dir = temp_dir("vtk");
  write_vtp(dir / "f.vtp", w.model, w.state);
  const std::string text = read_file(dir / "f.vtp");
  EXPECT_EQ(text.rfind("<?xml", 0), 0u);
  EXPECT_NE(text.find("NumberOfPoints=\"4\" NumberOfVerts=\"4\" NumberOfLines=\"" +
                      std::to_string(w.num_bonds() - 1) + "\""),
            std::string::npos);
  PvdSeries s;
  s.add(0.5, "f.vtp");
  s.write(dir / "s.pvd");
  EXPECT_NE(read_file(dir / "s.pvd").find("<DataSet timestep=\"0.5\" group=\"\" part=\"0\" file=\"f.vtp\"/>"),
            std::string::npos);
}

// A frame in pieces (a run over ranks): each piece holds its owned quanta and the bonds whose
// first end it owns, with the other ends as extra points; the pieces together hold every quanta
// once and every alive bond once, between the right positions, with the whole frame's strain.
TEST(Vtk, PiecesHoldEveryQuantaAndBondOnce) {
  World w = test::lattice(4, 3, 2, 100, 1e-3, 0.01, true);
  for (std::size_t i = 0; i < w.num_quanta(); ++i) w.state.x[i] += Vec3(1e-4 * static_cast<double>(i % 3), 0, 0);
  w.break_bond(3);
  const std::size_t n = w.num_quanta();
  const Bonds& b = w.state.bonds;
  std::vector<double> tension, strain;
  bond_tension_strain(w.model, w.state, tension, strain);
  const fs::path dir = temp_dir("vtp_pieces");
  std::size_t owned_total = 0, lines = 0, ends = 0;  // ends: points of other pieces' quanta
  for (int piece = 0; piece < 2; ++piece) {
    std::vector<std::uint8_t> owned(n), shown(b.size()), point(n);
    for (std::size_t q = 0; q < n; ++q) point[q] = owned[q] = (w.state.x[q].x() < 0.015) == (piece == 0);
    for (std::size_t k = 0; k < b.size(); ++k) {
      shown[k] = owned[b.i[k]];
      if (shown[k] && b.alive[k]) point[b.i[k]] = point[b.j[k]] = 1;
    }
    const fs::path file = dir / ("piece_" + std::to_string(piece) + ".vtp");
    write_vtp_piece(file, w.model, w.state, owned, shown);
    const VtpFrame f = read_vtp(file);
    // The points: the selected quanta in ascending user id (the lattice's ids are its indices).
    std::vector<Index> at;
    for (std::size_t q = 0; q < n; ++q)
      if (point[q]) at.push_back(static_cast<Index>(q));
    ASSERT_EQ(f.x.size(), at.size());
    for (std::size_t k = 0; k < at.size(); ++k) EXPECT_EQ(f.x[k], w.state.x[at[k]]);
    const auto mine = static_cast<std::size_t>(std::count(owned.begin(), owned.end(), 1));
    EXPECT_GT(mine, 0u);
    EXPECT_LT(mine, n);
    ends += at.size() - mine;
    owned_total += mine;
    std::size_t line = 0;
    for (std::size_t k = 0; k < b.size(); ++k) {
      if (!shown[k] || !b.alive[k]) continue;
      ASSERT_LT(line, f.lines.size());
      EXPECT_EQ(f.x[f.lines[line].first], w.state.x[b.i[k]]);
      EXPECT_EQ(f.x[f.lines[line].second], w.state.x[b.j[k]]);
      EXPECT_EQ(f.strain[line], strain[k]);
      ++line;
    }
    EXPECT_EQ(line, f.lines.size());
    lines += line;
  }
  EXPECT_EQ(owned_total, n);
  EXPECT_GT(ends, 0u);  // bonds cross the split
  EXPECT_EQ(lines, w.num_alive_bonds());
  const std::vector<std::string> names{"piece_0.vtp", "piece_1.vtp"};
  write_pvtp(dir / "frame.pvtp", names);
  const std::string text = read_file(dir / "frame.pvtp");
  EXPECT_NE(text.find("<VTKFile type=\"PPolyData\""), std::string::npos);
  EXPECT_NE(text.find("<Piece Source=\"piece_1.vtp\"/>"), std::string::npos);
  // Read back, the pieces are the whole frame (the viewer replays either), field by field.
  write_vtp(dir / "whole.vtp", w.model, w.state);
  const VtpFrame whole = read_vtp(dir / "whole.vtp"), joined = read_vtp(dir / "frame.pvtp");
  EXPECT_EQ(joined.x, whole.x);
  EXPECT_EQ(joined.v, whole.v);
  EXPECT_EQ(joined.mass, whole.mass);
  EXPECT_EQ(joined.body, whole.body);
  EXPECT_EQ(joined.kinematic, whole.kinematic);
  EXPECT_EQ(joined.von_mises, whole.von_mises);
  EXPECT_EQ(joined.lines, whole.lines);
  EXPECT_EQ(joined.strain, whole.strain);
  EXPECT_EQ(joined.tension, whole.tension);
  // A quanta held by no piece, or by two, is refused.
  write_pvtp(dir / "half.pvtp", std::vector<std::string>{"piece_0.vtp"});
  EXPECT_THROW(read_vtp(dir / "half.pvtp"), VtkReadError);
  write_pvtp(dir / "twice.pvtp", std::vector<std::string>{"piece_0.vtp", "piece_0.vtp", "piece_1.vtp"});
  EXPECT_THROW(read_vtp(dir / "twice.pvtp"), VtkReadError);
}

// The reader gets back what the writer wrote: points by user id, lines by bond id with their
// strain and tension (the vertex cells' entries dropped), the point arrays; and a series sorted
// by time with its files resolved against the .pvd's directory.
TEST(Vtk, ReaderGetsBackWhatTheWriterWrote) {
  World w = test::lattice(3, 2, 2, 100, 1e-3, 0.01, true);
  for (std::size_t i = 0; i < w.num_quanta(); ++i) {
    w.state.x[i] += Vec3(1e-4 * static_cast<double>(i % 3), -2e-4 * static_cast<double>(i % 2), 0);  // strain the bonds
    w.state.v[i] = Vec3(0.1 * static_cast<double>(i), 0, -0.2);
  }
  w.model.inv_mass[2] = 0;  // kinematic
  w.break_bond(1);
  const fs::path dir = temp_dir("vtp_reader");
  write_vtp(dir / "f.vtp", w.model, w.state);
  const VtpFrame f = read_vtp(dir / "f.vtp");
  const std::size_t n = w.num_quanta();
  ASSERT_EQ(f.x.size(), n);
  std::vector<double> tension, strain;
  bond_tension_strain(w.model, w.state, tension, strain);
  std::vector<Mat3> sigma;
  virial_stress(w.model, w.state, sigma);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t k = w.model.quanta_id[i];
    EXPECT_EQ(f.x[k], w.state.x[i]);
    EXPECT_EQ(f.v[k], w.state.v[i]);
    EXPECT_EQ(f.mass[k], w.model.mass[i]);
    EXPECT_EQ(f.kinematic[k], w.model.is_kinematic(static_cast<Index>(i)) ? 1 : 0);
    EXPECT_EQ(f.body[k], static_cast<std::int32_t>(w.model.body[i]));
    EXPECT_EQ(f.von_mises[k], von_mises(sigma[i]));
  }
  ASSERT_EQ(f.lines.size(), w.num_alive_bonds());
  ASSERT_EQ(f.strain.size(), f.lines.size());
  std::size_t line = 0;
  for (Index b : bonds_by_id(w.state.bonds)) {
    if (!w.state.bonds.alive[b]) continue;
    EXPECT_EQ(f.lines[line].first, w.model.quanta_id[w.state.bonds.i[b]]);
    EXPECT_EQ(f.lines[line].second, w.model.quanta_id[w.state.bonds.j[b]]);
    EXPECT_EQ(f.strain[line], strain[b]);
    EXPECT_EQ(f.tension[line], tension[b]);
    ++line;
  }
  EXPECT_GT(*std::max_element(f.strain.begin(), f.strain.end()), 0.0);

  PvdSeries s;
  s.add(0.25, "b.vtp");
  s.add(0.125, "a & b.vtp");
  s.write(dir / "s.pvd");
  const std::vector<PvdEntry> e = read_pvd(dir / "s.pvd");
  ASSERT_EQ(e.size(), 2u);
  EXPECT_EQ(e[0].time, 0.125);
  EXPECT_EQ(e[0].file, dir / "a & b.vtp");
  EXPECT_EQ(e[1].file, dir / "b.vtp");
}

// A frame cut short, another VTK encoding, or a collection of nothing is an error naming the file.
TEST(Vtk, ReaderRefusesWhatItCannotRead) {
  World w = test::lattice(2, 2, 1, 100, 1e-3, 0, false);
  const fs::path dir = temp_dir("vtp_reader_errors");
  write_vtp(dir / "f.vtp", w.model, w.state);
  const std::string text = read_file(dir / "f.vtp");
  write_file_atomic(dir / "cut.vtp", text.substr(0, text.size() - 100));
  EXPECT_THROW(read_vtp(dir / "cut.vtp"), VtkReadError);
  std::string ascii = text;
  ascii.replace(ascii.find("format=\"appended\""), 17, "format=\"ascii\"   ");
  write_file_atomic(dir / "ascii.vtp", ascii);
  try {
    read_vtp(dir / "ascii.vtp");
    ADD_FAILURE() << "an ASCII array was read";
  } catch (const VtkReadError& e) {
    EXPECT_NE(std::string(e.what()).find("ascii.vtp"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_vtp(dir / "missing.vtp"), VtkReadError);
  PvdSeries none;
  none.write(dir / "none.pvd");
  EXPECT_THROW(read_pvd(dir / "none.pvd"), VtkReadError);
}

// Frames list quanta by user id and bonds by bond id, so a renumbered world (ordering.hpp)
// writes the very same file. (At rest lengths every stress is exactly 0, which no summation
// order changes.)
TEST(Vtk, ARenumberedWorldWritesTheSameFile) {
  World w = test::lattice(4, 3, 2, 100, 1e-3, 0, true);
  for (std::size_t i = 0; i < w.num_quanta(); ++i) w.state.v[i] = Vec3(1.0 * i, 2.0 * i, 3.0 * i);
  w.break_bond(3);
  World r = w;
  Renumbering shuffle;
  const std::size_t n = w.num_quanta(), nb = w.num_bonds();
  // 7 and 24 are coprime: i -> 7 i + 3 (mod 24) is a permutation.
  for (std::size_t i = 0; i < n; ++i) shuffle.quanta.push_back(static_cast<Index>((7 * i + 3) % n));
  for (std::size_t b = 0; b < nb; ++b) shuffle.bonds.push_back(static_cast<Index>(nb - 1 - b));
  renumber(r, shuffle);
  ASSERT_NE(r.state.x, w.state.x);
  const fs::path dir = temp_dir("vtk_order");
  write_vtp(dir / "a.vtp", w.model, w.state);
  write_vtp(dir / "b.vtp", r.model, r.state);
  EXPECT_EQ(read_file(dir / "a.vtp"), read_file(dir / "b.vtp"));
}

}  // namespace
}  // namespace qbond
